"""Which part may be placed in which state, and the ground truth that follows (issue 2, SPEC §1).

Placing part p when the set S (a bitmask) is placed is feasible iff
- fixation holds: the first part is clamped (any profile may start); a later profile must touch a
  part of S; a bracket needs both profiles it joins in S (it is never first), and
- the robot has an option (arm, grasp, motion) that is `reachable` and whose `blockers & S == 0`.

The robot's options are computed once per part with all other parts present (`blockers` lists the
parts the swept gripper, held part and arm would penetrate), so enumerating the reachable states
with `GroundTruth.explore` is pure bitmask work, not N! simulations.

Diagnostics (`LabelledAssembly.info`), partitioning the infeasible assemblies by the weakest rule
set under which they are already infeasible:
- `cause = "other"`: infeasible under fixation alone;
- `cause = "collision"`: feasible under fixation alone, infeasible under fixation + clearance with
  reach ignored (every option counts as reachable);
- `cause = "reach"`: feasible under fixation + clearance, infeasible only once reach is required.
For feasible assemblies (`cause = None`):
- `robot_pruned`: the robot's rules (reach + clearance) remove complete orders that fixation alone
  allows (fewer `n_orders`);
- `nonlocal_block`: in some reachable state S some part p satisfies fixation, is not placeable, but
  would be if only the blockers p touches counted: a part it does not touch is what stops it.
`orders` is `n_orders()`, `fixation_orders` the count under fixation alone.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from grace.domain.assembly import Assembly
from grace.domain.motion import Motion
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly


class Option(Protocol):
    reachable: bool
    blockers: int


class Cell(Protocol):
    """What feasibility needs from the robot cell (grace.simulation.robot_cell.RobotCell)."""

    def placement_options(
        self, assembly: Assembly, part: int, motions: list[Motion]
    ) -> Sequence[Option]: ...

    def check_placement(
        self, assembly: Assembly, part: int, placed: int, motion: Motion
    ) -> bool: ...


@dataclass(frozen=True)
class Fixation:
    """Fixation rule per part: profiles need a touching placed part, brackets both profiles."""

    touch: tuple[int, ...]
    """Per part, bitmask of the parts it touches."""
    needs: tuple[int, ...]
    """Per bracket, bitmask of the profiles it joins (0 for profiles)."""
    is_profile: tuple[bool, ...]

    @classmethod
    def of(cls, assembly: Assembly, touch: np.ndarray) -> Fixation:
        masks = tuple(int(sum(1 << j for j in np.flatnonzero(row))) for row in touch)
        profiles = tuple(p.type.is_profile for p in assembly.parts)
        profile_mask = sum(1 << i for i, is_p in enumerate(profiles) if is_p)
        needs = tuple(
            0 if is_p else m & profile_mask for m, is_p in zip(masks, profiles, strict=True)
        )
        return cls(masks, needs, profiles)

    def holds(self, state: int, part: int) -> bool:
        if self.is_profile[part]:
            return state == 0 or bool(state & self.touch[part])
        need = self.needs[part]
        return need.bit_count() >= 2 and state & need == need


def _minimal(masks: list[int]) -> tuple[int, ...]:
    """Blocker masks with supersets of another mask dropped (they never decide anything)."""
    out: list[int] = []
    for m in sorted(set(masks), key=lambda m: (m.bit_count(), m)):
        if not any(o & m == o for o in out):
            out.append(m)
    return tuple(out)


@dataclass(frozen=True)
class PlacementTable:
    """The cached robot options of every part, reduced to blocker bitmasks."""

    fixation: Fixation
    reachable: tuple[tuple[int, ...], ...]
    """Per part, minimal blocker masks of its reachable options."""
    clearance: tuple[tuple[int, ...], ...]
    """Per part, minimal blocker masks of all options, reach ignored."""

    @classmethod
    def build(
        cls, assembly: Assembly, cell: Cell, motions: list[list[Motion]], touch: np.ndarray
    ) -> PlacementTable:
        reachable, clearance = [], []
        for part in range(assembly.n_parts):
            options = cell.placement_options(assembly, part, motions[part])
            reachable.append(_minimal([o.blockers for o in options if o.reachable]))
            clearance.append(_minimal([o.blockers for o in options]))
        return cls(Fixation.of(assembly, touch), tuple(reachable), tuple(clearance))

    def can_place(self, state: int, part: int) -> bool:
        return self.fixation.holds(state, part) and any(not b & state for b in self.reachable[part])

    def can_place_ignoring_reach(self, state: int, part: int) -> bool:
        return self.fixation.holds(state, part) and any(not b & state for b in self.clearance[part])

    def nonlocal_block(self, truth: GroundTruth) -> bool:
        """Some reachable state has a part stopped only by blockers it does not touch."""
        for state, placeable in zip(truth.states.tolist(), truth.placeable.tolist(), strict=True):
            for part, options in enumerate(self.reachable):
                if state >> part & 1 or placeable >> part & 1 or not options:
                    continue
                if not self.fixation.holds(state, part):
                    continue
                local = state & self.fixation.touch[part]
                if any(not b & local for b in options):
                    return True
        return False


def label(
    assembly: Assembly, cell: Cell, motions: list[list[Motion]], touch: np.ndarray
) -> LabelledAssembly:
    """Ground truth and diagnostics of one assembly (see the module docstring for `info`)."""
    table = PlacementTable.build(assembly, cell, motions, touch)
    n = assembly.n_parts
    truth = GroundTruth.explore(n, table.can_place)
    fixed = GroundTruth.explore(n, table.fixation.holds)
    info: dict[str, Any] = {
        "cause": None,
        "robot_pruned": False,
        "nonlocal_block": False,
        "orders": truth.n_orders(),
        "fixation_orders": fixed.n_orders(),
    }
    if truth.feasible:
        info["robot_pruned"] = info["orders"] < info["fixation_orders"]
        info["nonlocal_block"] = table.nonlocal_block(truth)
    elif not fixed.feasible:
        info["cause"] = "other"
    elif not GroundTruth.explore(n, table.can_place_ignoring_reach).feasible:
        info["cause"] = "collision"
    else:
        info["cause"] = "reach"
    return LabelledAssembly(assembly, truth, info)


def replay(
    assembly: Assembly,
    order: Sequence[int],
    cell: Cell,
    motions: list[list[Motion]],
    touch: np.ndarray,
) -> int | None:
    """Index of the first step of `order` that fails the uncached checks, None if all pass.

    Each step asks the robot directly with only the already placed parts in the scene, so a
    disagreement with `label` exposes a wrong cache.
    """
    fixation = Fixation.of(assembly, touch)
    placed = 0
    for step, part in enumerate(order):
        ok = fixation.holds(placed, part) and any(
            cell.check_placement(assembly, part, placed, m) for m in motions[part]
        )
        if not ok:
            return step
        placed |= 1 << part
    return None
