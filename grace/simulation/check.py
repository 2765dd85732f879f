"""Checking whole orders step by step in the robot cell, with reasons (docs/world.md, "Explain").

`OrderCheck` is what `task=plan` and the recordings show for a sequence: the verdict of each step
up to the first failing one, and there the rule that decides and what blocks it. A part's
placement options do not depend on the state, so an `OrderChecker` queries the cell once per part
and answers every (state, part) of one assembly from those options; `Simulator.explain` and
`Simulator.pose` recompute them per call, which costs N times more on a top-k list.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from grace.domain.assembly import Assembly
from grace.simulation.explain import Block, Verdict, explain
from grace.simulation.ground_truth import Fixation
from grace.simulation.joints import touching
from grace.simulation.robot_cell import CellPose, PlacementOption
from grace.simulation.simulator import Simulator


@dataclass(frozen=True)
class OrderCheck:
    """One order checked step by step: `verdicts[i]` places `order[i]`; the list stops at the
    first infeasible step (`failing_step`, None if every step is feasible)."""

    order: tuple[int, ...]
    verdicts: tuple[Verdict, ...]

    @property
    def failing_step(self) -> int | None:
        return next((i for i, v in enumerate(self.verdicts) if not v.feasible), None)

    @property
    def feasible(self) -> bool:
        return self.failing_step is None

    @property
    def failure(self) -> Verdict | None:
        step = self.failing_step
        return None if step is None else self.verdicts[step]


def blockers(verdict: Verdict) -> list[Block]:
    """What stops the placement under the deciding rule: one entry per (robot body, obstacle,
    part) over all candidates, in candidate order (empty when feasible or for fixation)."""
    seen: dict[tuple, Block] = {}
    for candidate in verdict.candidates:
        for block in candidate.blocks:
            if verdict.rule in (block.rule, "compound"):
                seen.setdefault((block.rule, block.body, block.obstacle, block.part), block)
    return list(seen.values())


def describe(verdict: Verdict, names: Sequence[str] | None = None) -> str:
    """One line: 'feasible', or the deciding rule and what blocks it ('fingers: finger hits
    part 3 (p3)')."""
    if verdict.feasible:
        return "feasible"
    if verdict.rule == "fixation":
        return "fixation: nothing placed holds it yet"

    def hit(block: Block) -> str:
        if block.part is None:
            return f"{block.body} {block.obstacle}"
        name = f" ({names[block.part]})" if names else ""
        what = "the clamp of part" if block.obstacle == "clamp" else "part"
        return f"{block.body} hits {what} {block.part}{name}"

    found = blockers(verdict)
    shown = "; ".join(hit(b) for b in found[:4])
    more = f"; +{len(found) - 4} more" if len(found) > 4 else ""
    return f"{verdict.rule}: {shown}{more}" if shown else str(verdict.rule)


class OrderChecker:
    """Verdicts and cell poses of one assembly under `simulator`, the cell queried once per part."""

    def __init__(self, simulator: Simulator, assembly: Assembly) -> None:
        self.simulator = simulator
        self.assembly = assembly
        self.scene = simulator.cell.scene(assembly)  # clamps designed once, not per part
        self.motions = simulator.motions(assembly, self.scene)
        self.fixation = Fixation.of(assembly, touching(assembly, simulator.tolerance))
        self._options: dict[int, list[PlacementOption]] = {}
        self._verdicts: dict[tuple[int, int], Verdict] = {}

    def options(self, part: int) -> list[PlacementOption]:
        if part not in self._options:
            cell = self.simulator.cell
            self._options[part] = cell.part_options(self.scene, part, self.motions[part])
        return self._options[part]

    def verdict(self, placed: int, part: int) -> Verdict:
        """As `Simulator.explain(assembly, placed, part)`."""
        key = (placed, part)
        if key not in self._verdicts:
            self._verdicts[key] = explain(
                part,
                placed,
                self.options(part),
                self.motions[part],
                self.fixation,
                self.simulator.rules,
            )
        return self._verdicts[key]

    def check(self, order: Sequence[int]) -> OrderCheck:
        """Verdicts of `order`'s steps up to and including the first infeasible one."""
        verdicts, placed = [], 0
        for part in order:
            verdict = self.verdict(placed, int(part))
            verdicts.append(verdict)
            if not verdict.feasible:
                break
            placed |= 1 << int(part)
        return OrderCheck(tuple(int(p) for p in order), tuple(verdicts))

    def pose(self, placed: int, part: int) -> CellPose | None:
        """As `Simulator.pose(assembly, placed, part)`: the cell placing `part`, None if it
        cannot be placed."""
        used = self.verdict(placed, part).used
        if used is None or not self.verdict(placed, part).feasible:
            return None
        option = next(
            o
            for o in self.options(part)
            if (o.arm, o.branch, o.grasp, o.motion)
            == (used.arm, used.branch, used.grasp, used.motion)
        )
        return self.simulator.cell.pose(self.assembly, placed, part, option)
