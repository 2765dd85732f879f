"""What a recording draws of a plan, gathered where the policy and the simulator live.

A `PlanView` is plain data (it crosses from an experiment's fold processes to the process that
writes `sequences.rrd`): the plan (grace/planning/plans.py), the ground truth if known, where
each order leaves it, the part scores and the robot cell at each step of the best order.
grace/visualisation/recording.py and search_recording.py only draw it (docs/recordings.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from grace.domain.assembly import Assembly
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.plans import Plan, PlannedOrder
from grace.planning.sequences import Scorer
from grace.planning.topk import StateScores, TopKListing, lazy_scores
from grace.simulation.check import OrderChecker, blockers, describe
from grace.simulation.robot_cell import CellPose
from grace.simulation.simulator import Simulator


@dataclass(frozen=True)
class Failure:
    """The first step of a listed order outside the ground truth (or, without one, the first
    step the simulator refuses), with what blocks it there."""

    rank: int
    step: int
    part: int
    placed: int
    rule: str | None
    """The simulator's deciding rule; None if the simulator places the part (a dead end: no
    feasible completion follows) or disagrees with the data set's ground truth."""
    blocking: tuple[int, ...]
    reason: str
    where: str
    """'leaves the ground truth' or 'is refused by the simulator' (no ground truth known)."""


@dataclass(frozen=True)
class StepView:
    """The best order at one step: the state before it, the part it places, every part's
    score in that state, and the cell placing it (None where the simulator cannot)."""

    placed: int
    part: int
    scores: np.ndarray
    pose: CellPose | None
    truth_next: int | None
    """Bitmask of the parts the ground truth lets go next from `placed` (None: no truth)."""


@dataclass
class PlanView:
    """One planned assembly as a recording shows it; `group` names it there (fold, size)."""

    group: str
    plan: Plan
    assembly: Assembly
    truth_orders: list[tuple[int, ...]]
    n_truth_orders: int | None
    failures: list[Failure]
    steps: list[StepView]
    clamps: dict[int, np.ndarray] = field(default_factory=dict)
    """Per part, its clamp's world boxes (k×2×3 mm; drawn once the part is placed)."""
    arm_links: tuple[tuple[float, float], ...] = ()
    """(length, radius) in mm of each arm link's capsule: column, upper arm, forearm, wrist."""

    @property
    def feasibility(self) -> float | None:
        """The top-k listing's feasibility score (None for a verified search's plan)."""
        return self.plan.listing.feasibility if self.plan.listing is not None else None


def _label(truth: GroundTruth | None, state: int) -> int | None:
    if truth is None:
        return None
    try:
        return truth.label(state)
    except KeyError:
        return 0


def first_failure(
    order: PlannedOrder, checker: OrderChecker, truth: GroundTruth | None
) -> Failure | None:
    """The failure step of one planned order: outside `truth` if given, else refused by the
    simulator; None if it is a ground-truth (or simulator-feasible) order."""
    placed = 0
    names = [p.name for p in checker.assembly.parts]
    for step, part in enumerate(order.sequence):
        label = _label(truth, placed)
        outside = not (label >> part & 1) if label is not None else False
        verdict = checker.verdict(placed, part)
        if outside or (truth is None and not verdict.feasible):
            where = "leaves the ground truth" if outside else "is refused by the simulator"
            if verdict.feasible:
                reason = "the simulator places it, but no ground-truth order goes on from here"
                return Failure(order.rank, step, part, placed, None, (), reason, where)
            hits = tuple(sorted({b.part for b in blockers(verdict) if b.part is not None}))
            reason = describe(verdict, names)
            return Failure(order.rank, step, part, placed, verdict.rule, hits, reason, where)
        placed |= 1 << part
    return None


def _clamps(simulator: Simulator, assembly: Assembly) -> dict[int, np.ndarray]:
    scene = simulator.cell.scene(assembly)
    return {
        p: np.stack([scene.lo[keep], scene.hi[keep]], axis=1)
        for p in range(assembly.n_parts)
        if (keep := (scene.owner == p) & (scene.kind == 1)).any()
    }


def plan_view(
    group: str,
    plan: Plan,
    checker: OrderChecker,
    scores: StateScores,
    truth: GroundTruth | None,
    truth_orders: int = 5,
) -> PlanView:
    """`plan` of `checker`'s assembly as drawn: where each order fails, and the best order's
    cell and part scores (`scores(state)`) at every step, the clamps and the arms (the cell
    poses cost about as much as the checks)."""
    simulator = checker.simulator
    steps, placed = [], 0
    for part in plan.orders[0].sequence if plan.orders else ():
        pose = checker.pose(placed, part)
        steps.append(
            StepView(placed, part, np.asarray(scores(placed)), pose, _label(truth, placed))
        )
        placed |= 1 << part
    arm = simulator.cell.config.arm
    return PlanView(
        group=group,
        plan=plan,
        assembly=checker.assembly,
        truth_orders=list(truth.orders(limit=truth_orders)) if truth is not None else [],
        n_truth_orders=truth.n_orders() if truth is not None else None,
        failures=[f for o in plan.orders if (f := first_failure(o, checker, truth)) is not None],
        steps=steps,
        clamps=_clamps(simulator, checker.assembly),
        arm_links=tuple(
            (float(length), float(radius))
            for length, radius in zip(arm.link_lengths, arm.link_radii, strict=True)
        ),
    )


def fold_views(
    scorer: Scorer,
    test: Sequence[LabelledAssembly],
    simulator: Simulator,
    per_size: int,
    top_k: int,
    truth_orders: int,
    fold: int,
) -> list[PlanView]:
    """The first `per_size` test assemblies of each size of one fold, each listed (its `top_k`
    best sequences, checked) and drawn (an experiment's sequences.rrd)."""
    chosen: dict[int, list[LabelledAssembly]] = {}
    for sample in test:
        group = chosen.setdefault(sample.size, [])
        if len(group) < per_size:
            group.append(sample)
    views = []
    listing = TopKListing(k=top_k)
    for size in sorted(chosen):
        for sample in chosen[size]:
            steps = SimulatorSteps(simulator, sample.assembly)
            plan = listing.checked_plan(scorer, sample.assembly, steps, sample.truth)
            scores = lazy_scores(scorer, sample.assembly)
            group = f"fold_{fold}/A{size}"
            views.append(plan_view(group, plan, steps.checker, scores, sample.truth, truth_orders))
    return views
