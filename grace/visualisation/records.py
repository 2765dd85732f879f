"""What a recording shows of one assembly, gathered where the policy and the simulator live.

A `SequenceRecord` is plain data (it crosses from an experiment's fold processes to the process
that writes `sequences.rrd`): the policy's best sequences with their simulator checks, the
ground truth if known, the part scores and the robot cell at each step of the best sequence. A
`SearchRecord` is a verified search (task=plan's plan.json and plan.rrd). Gathering them needs no
rerun: they are written by grace/visualisation/recording.py and search_recording.py.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from grace.domain.assembly import Assembly, mask_to_parts
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.search import SearchResult
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
    cell: bool = True,
) -> SequenceRecord:
    """Check listed sequences of `checker`'s assembly and, with `cell`, pose them
    (:func:`with_cell`); `scores(state)` gives the policy's part scores of a state."""
    assembly = checker.assembly
    checks = [checker.check(r.sequence) for r in ranked]
    failures = [
        f
        for rank, check in enumerate(checks, 1)
        if (f := first_failure(rank, check, checker, truth)) is not None
    ]
    record = SequenceRecord(
        group=group,
        assembly=assembly,
        ranked=ranked,
        checks=checks,
        feasibility=feasibility,
        truth_orders=list(truth.orders(limit=truth_orders)) if truth is not None else [],
        n_truth_orders=truth.n_orders() if truth is not None else None,
        failures=failures,
        steps=[],
    )
    return with_cell(record, scores, checker, truth) if cell else record


def with_cell(
    record: SequenceRecord, scores: StateScores, checker: OrderChecker, truth: GroundTruth | None
) -> SequenceRecord:
    """`record` with what a recording draws and nothing else reads: the first sequence's cell
    and part scores at every step, the clamps and the arms (the cell poses cost about as much
    as the checks)."""
    simulator = checker.simulator
    steps, placed = [], 0
    for part in record.ranked[0].sequence if record.ranked else ():
        pose = checker.pose(placed, part)
        steps.append(
            StepView(placed, part, np.asarray(scores(placed)), pose, _label(truth, placed))
        )
        placed |= 1 << part
    arm = simulator.cell.config.arm
    return replace(
        record,
        steps=steps,
        clamps=_clamps(simulator, record.assembly),
        arm_links=tuple(
            (float(length), float(radius))
            for length, radius in zip(arm.link_lengths, arm.link_radii, strict=True)
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


@dataclass(frozen=True)
class SearchStep:
    """One search event as drawn: `kind` as `SearchEvent.kind`, the state, the part tried,
    the checks spent so far, the parts that block it and the deciding rule (refusals), and one
    line of reason."""

    kind: str
    state: int
    part: int
    checks: int
    blocking: tuple[int, ...]
    rule: str | None
    reason: str


@dataclass
class SearchRecord:
    """A verified search of one assembly as plan.rrd shows it (search_recording.py)."""

    order: SequenceRecord
    outcome: str
    checks: int
    seconds: float
    first_checks: int | None
    expanded: int
    steps: list[SearchStep]
    events: int
    """All events of the search; `steps` holds the first ones only (`max_events`)."""
    unplaceable: int | None = None
    """The part no order can place, when that proved the assembly infeasible before any step
    check (SearchResult.unplaceable)."""


def search_record(
    group: str,
    result: SearchResult,
    scores: StateScores,
    oracle: SimulatorSteps,
    truth: GroundTruth | None,
    truth_orders: int = 5,
    max_events: int = 2000,
    cell: bool = True,
) -> SearchRecord:
    """What plan.rrd shows of `result` (its first `max_events` events); without `cell`, what
    plan.json reads of it only (:func:`with_cell` adds the rest)."""
    checker = oracle.checker
    names = [p.name for p in checker.assembly.parts]
    steps = []
    for event in result.events[:max_events]:
        if event.kind == "refused":
            verdict = checker.verdict(event.state, event.part)
            hit = tuple(sorted({b.part for b in blockers(verdict) if b.part is not None}))
            steps.append(
                SearchStep(
                    event.kind, event.state, event.part, event.checks, hit, verdict.rule,
                    describe(verdict, names),
                )
            )  # fmt: skip
        elif event.kind == "ruled_out":
            hit = tuple(mask_to_parts(event.blocked_by or 0))
            reason = f"ruled out: part {event.part} cannot be placed once parts {list(hit)} are"
            steps.append(
                SearchStep(event.kind, event.state, event.part, event.checks, hit, None, reason)
            )
        else:
            steps.append(
                SearchStep(event.kind, event.state, event.part, event.checks, (), None, "placed")
            )
    order = ranked_record(group, result.orders, scores, checker, truth, truth_orders, cell=cell)
    return SearchRecord(
        order=order,
        outcome=str(result.outcome),
        checks=result.checks,
        seconds=result.seconds,
        first_checks=result.first_checks,
        expanded=result.expanded,
        steps=steps,
        events=len(result.events),
        unplaceable=result.unplaceable,
    )
