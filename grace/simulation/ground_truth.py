"""Which part may be placed in which state, the ground truth that follows, and why (docs/world.md).

Placing part p when the set S (a bitmask) is placed is feasible iff
- fixation holds: the first part is a profile (clamped or not: one the fixture designer found no
  spot for may go first too, docs/world.md, "Rules"); a later profile touches a part of S; a
  bracket needs one of the two profiles it joins in S (it is fastened to it), and
- the cell has an option (arm, IK branch, grasp, motion) that is usable (reach: IK within the
  limits along the motion; arm links: clear of table and itself; with the clamps rule, no robot
  body of an active rule hits a clamp's base, which stands from the start, or its own open
  clamp), none of whose blocker masks for the active rules meets S, and whose needs (the parts
  whose open clamps it would hit, there until they are placed) lie in S.

The cell's options are computed once per part with all other parts present, so enumerating the
reachable states (`GroundTruth.explore_many`) is bitmask work, not N! simulations. Switching a
rule off drops its masks (or its usability test), so the same table also gives the ground truth
of every single-rule ablation and of every mechanism relaxation.

Diagnostics (`LabelledAssembly.info`):
- `cause` (infeasible only): "other" if fixation alone leaves no order, "collision" if no order
  exists even with reach ignored, else "reach";
- `mechanisms` (infeasible only): the mechanisms (`MECHANISMS`) whose relaxation alone makes the
  assembly feasible, or ["compound"] if none alone does;
- `decisive_rules`: the rules whose switching off alone changes the set of complete orders;
- `robot_pruned` (feasible only): fewer orders than under fixation alone;
- `nonlocal_block` (feasible only): in some reachable state a part that satisfies fixation is
  stopped only by parts it does not touch;
- `orders`, `fixation_orders`: order counts of the truth and of fixation alone.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from grace.domain.assembly import Assembly
from grace.domain.motion import Motion
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.simulation.cell_config import MECHANISMS, RULES
from grace.simulation.robot_cell import BODIES, KINDS, RULE_OF_BODY, PlacementOption, category


class Cell(Protocol):
    """What `replay` needs from the robot cell (grace.simulation.robot_cell.RobotCell)."""

    def check_placement(
        self,
        assembly: Assembly,
        part: int,
        placed: int,
        motion: Motion,
        rules: dict[str, bool] | None = None,
    ) -> bool: ...


@dataclass(frozen=True)
class Fixation:
    """Fixation rule per part: profiles need a touching placed part (the first one none, with
    or without a clamp), brackets one profile."""

    touch: np.ndarray
    """Per part, bitmask of the parts it touches (int64)."""
    needs: np.ndarray
    """Per bracket, bitmask of the profiles it joins (0 for profiles)."""
    is_profile: np.ndarray

    @classmethod
    def of(cls, assembly: Assembly, touch: np.ndarray) -> Fixation:
        masks = np.array(
            [sum(1 << int(j) for j in np.flatnonzero(row)) for row in touch], dtype=np.int64
        )
        profiles = np.array([p.type.is_profile for p in assembly.parts], dtype=bool)
        profile_mask = sum(1 << i for i, is_p in enumerate(profiles) if is_p)
        needs = np.where(profiles, 0, masks & profile_mask).astype(np.int64)
        return cls(masks, needs, profiles)

    def holds(self, states: np.ndarray, part: int) -> np.ndarray:
        """Vectorised over int64 `states` (scalars work too)."""
        states = np.asarray(states, dtype=np.int64)
        if self.is_profile[part]:
            return (states == 0) | ((states & self.touch[part]) != 0)
        return (states & self.needs[part]) != 0


@dataclass(frozen=True)
class OptionTable:
    """Every option of every part of one assembly, as arrays."""

    part: np.ndarray
    masks: np.ndarray
    """(options × categories) int64 blocker masks, columns as `robot_cell.category`."""
    reachable: np.ndarray
    arm_clear: np.ndarray
    is_profile: np.ndarray
    touch: np.ndarray
    parallel: np.ndarray
    """Per part, bitmask of the other parts lying along the same axis."""

    @classmethod
    def build(
        cls, assembly: Assembly, options: list[list[PlacementOption]], fixation: Fixation
    ) -> OptionTable:
        flat = [(p, o) for p, opts in enumerate(options) for o in opts]
        turns = np.array([p.quarter_turns % 2 for p in assembly.parts])
        same = turns[:, None] == turns[None, :]
        np.fill_diagonal(same, False)
        bits = np.int64(1) << np.arange(len(turns), dtype=np.int64)
        return cls(
            part=np.array([p for p, _ in flat], dtype=int),
            masks=np.array([o.masks for _, o in flat], dtype=np.int64).reshape(len(flat), -1),
            reachable=np.array([o.reachable for _, o in flat], dtype=bool),
            arm_clear=np.array([o.arm_clear for _, o in flat], dtype=bool),
            is_profile=fixation.is_profile,
            touch=fixation.touch,
            parallel=np.where(same, bits[None, :], 0).sum(axis=1, dtype=np.int64),
        )

    def blockers(self, rules: Collection[str], relax: str | None = None) -> list[np.ndarray]:
        """Per part, the minimal (blockers, needs) mask pairs (k×2) of its usable options under
        `rules` (the active ones), with mechanism `relax` lifted: an option is free in state S
        iff `S & blockers == 0` and `S & needs == needs`."""
        cols = [
            category(body, kind)
            for body in BODIES
            for kind in KINDS
            if RULE_OF_BODY[body] in rules and (kind == "part" or "clamps" in rules)
        ]
        of_kind = {k: [c for c in cols if KINDS[c % len(KINDS)] == k] for k in KINDS}
        masks = self.masks.copy()
        usable = np.ones(len(self.part), dtype=bool)
        if "reach" in rules and relax != "reach":
            usable &= self.reachable
        if "arm_links" in rules and relax != "arm":
            usable &= self.arm_clear
        if relax is not None:
            _relax(masks, relax, self)

        def union(kinds: tuple[str, ...]) -> np.ndarray:
            picked = [c for k in kinds for c in of_kind[k]]
            if not picked:
                return np.zeros(len(masks), np.int64)
            return np.bitwise_or.reduce(masks[:, picked], axis=1)

        needs = union(("open",))
        # A clamp's base stands from the start and a part's own open clamp while it is placed:
        # an option that hits either is unusable in every state.
        usable &= (union(("post",)) == 0) & ((needs >> self.part) & 1 == 0)
        pairs = np.stack([union(("part", "clamp")), needs], axis=1)
        n = len(self.is_profile)
        return [_minimal(pairs[usable & (self.part == p)]) for p in range(n)]


def _relax(masks: np.ndarray, mechanism: str, table: OptionTable) -> None:
    """Lift one mechanism's blocking contributions from `masks` in place (docs/world.md)."""
    part = table.part
    held = category("held_part", "part")
    gripper = [category("finger", "part"), category("palm", "part")]
    if mechanism == "frame_closing":
        masks[:, category("joint", "part")] = 0
        masks[:, held] &= ~table.touch[part]
    elif mechanism == "slide_corridor":
        masks[:, held] &= table.touch[part]
    elif mechanism in ("narrow_rails", "crowded_grasp", "bracket_corner"):
        # Which blockers of a gripper belong to the mechanism: parallel profiles beside a
        # profile, crossing profiles over it, anything involving a bracket.
        brackets = np.int64(sum(1 << i for i, p in enumerate(table.is_profile) if not p))
        same = table.parallel[part]
        moving_profile = table.is_profile[part]
        lift = {
            "narrow_rails": np.where(moving_profile, same & ~brackets, 0),
            "crowded_grasp": np.where(moving_profile, ~same & ~brackets, 0),
            "bracket_corner": np.where(moving_profile, brackets, -1),
        }[mechanism].astype(np.int64)
        for c in gripper:
            masks[:, c] &= ~lift
    elif mechanism == "clamp":
        for body in ("finger", "palm", "held_part"):
            for kind in KINDS[1:]:
                masks[:, category(body, kind)] = 0
    elif mechanism == "arm":
        for body in BODIES:
            if body.startswith("arm_"):
                for kind in KINDS:
                    masks[:, category(body, kind)] = 0


def _minimal(pairs: np.ndarray) -> np.ndarray:
    """(blockers, needs) pairs with those dropped that another pair's blockers and needs are
    both subsets of (they never decide anything)."""
    out: list[tuple[int, int]] = []
    rows = {(int(b), int(n)) for b, n in pairs.tolist()}
    for b, n in sorted(rows, key=lambda r: (r[0].bit_count() + r[1].bit_count(), r)):
        if not any(ob & b == ob and on & n == on for ob, on in out):
            out.append((b, n))
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def _same(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def rule_check(
    fixation: Fixation, blockers: list[np.ndarray], fixation_on: bool = True
) -> Callable[[np.ndarray, int], np.ndarray]:
    """`can_place(states, part)` for `GroundTruth.explore_many`."""

    def can_place(states: np.ndarray, part: int) -> np.ndarray:
        pairs = blockers[part]
        if not len(pairs):
            return np.zeros(len(states), dtype=bool)
        block, need = pairs[None, :, 0], pairs[None, :, 1]
        s = states[:, None]
        free = (((s & block) == 0) & ((s & need) == need)).any(axis=1)
        return free & fixation.holds(states, part) if fixation_on else free

    return can_place


def explore(
    n: int, fixation: Fixation, table: OptionTable, rules: Collection[str], relax: str | None = None
) -> GroundTruth:
    """Ground truth under the active `rules` (and mechanism `relax` lifted)."""
    check = rule_check(fixation, table.blockers(rules, relax), "fixation" in rules)
    return GroundTruth.explore_many(n, check, naive_checks=False)


def nonlocal_block(truth: GroundTruth, fixation: Fixation, blockers: list[np.ndarray]) -> bool:
    """Some reachable state has a part stopped only by parts it does not touch (placed ones in
    its way, or missing ones whose open clamps are)."""
    states, placeable = truth.states, truth.placeable
    for part, pairs in enumerate(blockers):
        if not len(pairs):
            continue
        bit = np.int64(1) << part
        idle = ((states & bit) == 0) & ((placeable & bit) == 0) & fixation.holds(states, part)
        if not idle.any():
            continue
        touch = fixation.touch[part]
        local = (states[idle] & touch)[:, None]
        need = pairs[None, :, 1] & touch
        if (((local & pairs[None, :, 0]) == 0) & ((local & need) == need)).any():
            return True
    return False


def orders(
    assembly: Assembly,
    options: list[list[PlacementOption]],
    touch: np.ndarray,
    rules: Collection[str] = RULES,
    first: int | None = None,
) -> GroundTruth:
    """The ground truth of `label` alone: every feasible order under the active `rules`, only
    those starting with part `first` if given."""
    fixation = Fixation.of(assembly, touch)
    active = [r for r in RULES if r in rules]
    blockers = OptionTable.build(assembly, options, fixation).blockers(active)
    check = rule_check(fixation, blockers, "fixation" in active)
    if first is None:
        return GroundTruth.explore_many(assembly.n_parts, check)

    def starting(states: np.ndarray, part: int) -> np.ndarray:
        return check(states, part) & ((states != 0) | (part == first))

    return GroundTruth.explore_many(assembly.n_parts, starting)


def label(
    assembly: Assembly,
    options: list[list[PlacementOption]],
    touch: np.ndarray,
    rules: Collection[str] = RULES,
) -> LabelledAssembly:
    """Ground truth and diagnostics of one assembly (see the module docstring for `info`)."""
    n = assembly.n_parts
    fixation = Fixation.of(assembly, touch)
    table = OptionTable.build(assembly, options, fixation)
    active = [r for r in RULES if r in rules]
    blockers = table.blockers(active)
    truth = GroundTruth.explore_many(n, rule_check(fixation, blockers, "fixation" in active))
    fixed = GroundTruth.explore_many(n, fixation.holds, naive_checks=False)

    def decides(rule: str) -> bool:
        rest = [x for x in active if x != rule]
        other = table.blockers(rest)
        # A rule that changes no part's blocker masks cannot change the orders: skip its search.
        if rule != "fixation" and _same(other, blockers):
            return False
        check = rule_check(fixation, other, "fixation" in rest)
        return not GroundTruth.explore_many(n, check, naive_checks=False).same_orders(truth)

    decisive = [r for r in active if decides(r)]
    info: dict[str, Any] = {
        "cause": None,
        "mechanisms": [],
        "decisive_rules": decisive,
        "robot_pruned": False,
        "nonlocal_block": False,
        "orders": truth.n_orders(),
        "fixation_orders": fixed.n_orders(),
    }
    if truth.feasible:
        info["robot_pruned"] = info["orders"] < info["fixation_orders"]
        info["nonlocal_block"] = nonlocal_block(truth, fixation, blockers)
        return LabelledAssembly(assembly, truth, info)
    if not fixed.feasible:
        info["cause"] = "other"
    elif not explore(n, fixation, table, [r for r in active if r != "reach"]).feasible:
        info["cause"] = "collision"
    else:
        info["cause"] = "reach"

    def lifts(mechanism: str) -> bool:
        relaxed = table.blockers(active, mechanism)
        if _same(relaxed, blockers):  # nothing of it blocks here: still infeasible
            return False
        check = rule_check(fixation, relaxed, "fixation" in active)
        return GroundTruth.explore_many(n, check, naive_checks=False).feasible

    found = [m for m in MECHANISMS if lifts(m)]
    info["mechanisms"] = found or ["compound"]
    return LabelledAssembly(assembly, truth, info)


def replay(
    assembly: Assembly,
    order: Sequence[int],
    cell: Cell,
    motions: list[list[Motion]],
    touch: np.ndarray,
    rules: Collection[str] = RULES,
) -> int | None:
    """Index of the first step of `order` that fails the uncached checks, None if all pass.

    Each step asks the cell directly with only the already placed parts in the scene, so a
    disagreement with `label` exposes a wrong cache.
    """
    step_check = uncached_check(assembly, cell, motions, touch, rules)
    placed = 0
    for step, part in enumerate(order):
        if not step_check(placed, part):
            return step
        placed |= 1 << part
    return None


def replayed_truth(
    assembly: Assembly,
    cell: Cell,
    motions: list[list[Motion]],
    touch: np.ndarray,
    rules: Collection[str] = RULES,
) -> GroundTruth:
    """The ground truth `replay` implies: every reachable state's every part asked the uncached
    check once, as replaying all N! orders would (their steps share prefixes). It equals
    `label`'s truth iff every listed order replays and no other does."""
    return GroundTruth.explore(
        assembly.n_parts, uncached_check(assembly, cell, motions, touch, rules)
    )


def uncached_check(
    assembly: Assembly,
    cell: Cell,
    motions: list[list[Motion]],
    touch: np.ndarray,
    rules: Collection[str] = RULES,
) -> Callable[[int, int], bool]:
    """`can_place(placed, part)` asking the cell directly: fixation, then some motion that
    `Cell.check_placement` lets through with only the parts of `placed` in the scene."""
    fixation = Fixation.of(assembly, touch)
    switches = {r: r in rules for r in RULES}

    def can_place(placed: int, part: int) -> bool:
        fixed = not switches["fixation"] or bool(fixation.holds(np.int64(placed), part))
        return fixed and any(
            cell.check_placement(assembly, part, placed, m, switches) for m in motions[part]
        )

    return can_place
