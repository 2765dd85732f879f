"""What a recording shows of one assembly, gathered where the policy and the simulator live.

A `SequenceRecord` is plain data (it crosses from an experiment's fold processes to the process
that writes `sequences.rrd`): the policy's best sequences with their simulator checks, the
ground truth if known, the part scores and the robot cell at each step of the best sequence.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from grace.domain.assembly import Assembly
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.planning.sequences import Scorer
from grace.planning.topk import Ranked, StateScores, rank_sequences
from grace.simulation.check import OrderCheck, OrderChecker, blockers, describe
from grace.simulation.robot_cell import CellPose
from grace.simulation.simulator import Simulator


@dataclass
class RecordingSettings:
    """Schema of `task.recording` (what an experiment's `sequences.rrd` holds)."""

    per_size: int = 2  # test assemblies recorded per test size and fold (0: no recording)
    top_k: int = 3  # predicted sequences listed per assembly, best first
    truth_orders: int = 5  # ground-truth orders listed per assembly


@dataclass(frozen=True)
class Failure:
    """The first step of a listed sequence outside the ground truth (or, without one, the first
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
    """The best sequence at one step: the state before it, the part it places, every part's
    score in that state, and the cell placing it (None where the simulator cannot)."""

    placed: int
    part: int
    scores: np.ndarray
    pose: CellPose | None
    truth_next: int | None
    """Bitmask of the parts the ground truth lets go next from `placed` (None: no truth)."""


@dataclass
class SequenceRecord:
    """One assembly as the recording shows it; `group` names it in the recording (fold, size)."""

    group: str
    assembly: Assembly
    ranked: list[Ranked]
    checks: list[OrderCheck]
    feasibility: float | None
    truth_orders: list[tuple[int, ...]]
    n_truth_orders: int | None
    failures: list[Failure]
    steps: list[StepView]
    clamps: dict[int, np.ndarray] = field(default_factory=dict)
    """Per part, its clamp's world boxes (k×2×3 mm; drawn once the part is placed)."""
    arm_links: tuple[tuple[float, float], ...] = ()
    """(length, radius) in mm of each arm link's capsule: column, upper arm, forearm, wrist."""


def _label(truth: GroundTruth | None, state: int) -> int | None:
    if truth is None:
        return None
    try:
        return truth.label(state)
    except KeyError:
        return 0


def first_failure(
    rank: int, check: OrderCheck, checker: OrderChecker, truth: GroundTruth | None
) -> Failure | None:
    """The failure step of one listed sequence: outside `truth` if given, else refused by the
    simulator; None if it is a ground-truth (or simulator-feasible) order."""
    placed = 0
    names = [p.name for p in checker.assembly.parts]
    for step, part in enumerate(check.order):
        label = _label(truth, placed)
        outside = not (label >> part & 1) if label is not None else False
        verdict = checker.verdict(placed, part)
        if outside or (truth is None and not verdict.feasible):
            where = "leaves the ground truth" if outside else "is refused by the simulator"
            if verdict.feasible:
                reason = "the simulator places it, but no ground-truth order goes on from here"
                return Failure(rank, step, part, placed, None, (), reason, where)
            hits = tuple(sorted({b.part for b in blockers(verdict) if b.part is not None}))
            reason = describe(verdict, names)
            return Failure(rank, step, part, placed, verdict.rule, hits, reason, where)
        placed |= 1 << part
    return None


def _clamps(simulator: Simulator, assembly: Assembly) -> dict[int, np.ndarray]:
    scene = simulator.cell.scene(assembly)
    return {
        p: np.stack([scene.lo[keep], scene.hi[keep]], axis=1)
        for p in range(assembly.n_parts)
        if (keep := (scene.owner == p) & (scene.kind == 1)).any()
    }


def sequence_record(
    group: str,
    assembly: Assembly,
    scorer: Scorer,
    simulator: Simulator,
    truth: GroundTruth | None,
    top_k: int,
    truth_orders: int,
) -> SequenceRecord:
    """Rank, check and pose one assembly (the best sequence's cell at every step)."""
    ranking = rank_sequences(scorer, assembly, top_k)
    checker = OrderChecker(simulator, assembly)
    return ranked_record(
        group, ranking.ranked, ranking.scores, checker, truth, truth_orders, ranking.feasibility
    )


def ranked_record(
    group: str,
    ranked: list[Ranked],
    scores: StateScores,
    checker: OrderChecker,
    truth: GroundTruth | None,
    truth_orders: int,
    feasibility: float | None = None,
) -> SequenceRecord:
    """Check and pose listed sequences of `checker`'s assembly (the first one's cell at every
    step); `scores(state)` gives the policy's part scores of a state."""
    assembly, simulator = checker.assembly, checker.simulator
    checks = [checker.check(r.sequence) for r in ranked]
    failures = [
        f
        for rank, check in enumerate(checks, 1)
        if (f := first_failure(rank, check, checker, truth)) is not None
    ]
    steps, placed = [], 0
    for part in ranked[0].sequence if ranked else ():
        pose = checker.pose(placed, part)
        steps.append(
            StepView(placed, part, np.asarray(scores(placed)), pose, _label(truth, placed))
        )
        placed |= 1 << part
    return SequenceRecord(
        group=group,
        assembly=assembly,
        ranked=ranked,
        checks=checks,
        feasibility=feasibility,
        truth_orders=list(truth.orders(limit=truth_orders)) if truth is not None else [],
        n_truth_orders=truth.n_orders() if truth is not None else None,
        failures=failures,
        steps=steps,
        clamps=_clamps(simulator, assembly),
        arm_links=tuple(
            (float(length), float(radius))
            for length, radius in zip(
                simulator.cell.config.arm.link_lengths,
                simulator.cell.config.arm.link_radii,
                strict=True,
            )
        ),
    )


def fold_records(
    scorer: Scorer,
    test: Sequence[LabelledAssembly],
    simulator: Simulator,
    settings: RecordingSettings,
    fold: int,
) -> list[SequenceRecord]:
    """Records of the first `settings.per_size` test assemblies of each size of one fold."""
    chosen: dict[int, list[LabelledAssembly]] = {}
    for sample in test:
        group = chosen.setdefault(sample.size, [])
        if len(group) < settings.per_size:
            group.append(sample)
    return [
        sequence_record(
            f"fold_{fold}/A{size}",
            sample.assembly,
            scorer,
            simulator,
            sample.truth,
            settings.top_k,
            settings.truth_orders,
        )
        for size in sorted(chosen)
        for sample in chosen[size]
    ]
