"""The checked plan: what either planner answers for one assembly (docs/planning.md, "plan.json").

Both planners (the verified search, grace/planning/search.py; the top-k listing of Algorithm 1,
paper Sec. IV-C.3, grace/planning/topk.py) return a `Plan`: its orders best first, each with the
network's probability and step scores and the simulator's verdict on every step up to the first
refused one (with its rule, blocking parts and reason). The verified search adds what it cost,
the steps it saw refused and, when the assembly is infeasible without a search, the part no
order can place (`Proof`); the listing adds the feasibility score (docs/metrics.md) and the
number of ground-truth orders. plan.json is written and read by grace/planning/plan_file.py.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from grace.domain.assembly import mask_to_parts
from grace.domain.orders import GroundTruth
from grace.simulation.check import OrderCheck, OrderChecker, blockers, describe

if TYPE_CHECKING:  # the planners import this module
    from grace.planning.search import SearchResult
    from grace.planning.topk import Ranked, Ranking

REFUSALS_LISTED = 20
"""Refused steps listed in plan.json (all are counted, by rule)."""

LISTED = "listed"
"""The top-k listing's outcome: its sequences are listed, then checked (none is verified)."""


@dataclass(frozen=True)
class StepVerdicts:
    """The simulator's verdicts on one order's steps, up to and including the first refused
    one (`failing_step`, 0-based, None when every step is feasible), and there the deciding
    rule, the placed parts that block it and one line of reason."""

    feasible: bool
    verdicts: tuple[bool, ...]
    failing_step: int | None = None
    rule: str | None = None
    blocking_parts: tuple[int, ...] = ()
    reason: str | None = None


@dataclass(frozen=True)
class PlannedOrder:
    """One order of a plan: `ground_truth` says whether the raw folder's ground truth holds it
    (None: none given)."""

    rank: int
    sequence: tuple[int, ...]
    parts: tuple[str, ...]
    probability: float
    step_scores: tuple[float, ...]
    simulator: StepVerdicts
    ground_truth: bool | None


@dataclass(frozen=True)
class RefusedStep:
    """A step the verified search asked the simulator about and saw refused."""

    placed: tuple[int, ...]
    part: int
    rule: str | None
    blocking_parts: tuple[int, ...]
    reason: str


@dataclass(frozen=True)
class Refusals:
    """The refused steps of a verified search: counted, by rule, and the first ones listed."""

    count: int
    by_rule: dict[str, int]
    first: tuple[RefusedStep, ...]


@dataclass(frozen=True)
class Proof:
    """The part no order can place, when that proved the assembly infeasible before any step
    check (docs/planning.md, "Infeasibility without a search")."""

    part: int
    name: str
    reason: str


@dataclass(frozen=True)
class SearchStep:
    """One search event as plan.rrd draws it: `kind` as `SearchEvent.kind`, the state, the part
    tried, the checks spent so far, the parts that block it and the deciding rule (refusals),
    and one line of reason."""

    kind: str
    state: int
    part: int
    checks: int
    blocking: tuple[int, ...]
    rule: str | None
    reason: str


@dataclass(frozen=True)
class SearchFacts:
    """What the verified search cost and saw. `events` (the first ones, with their reasons) and
    `n_events` are for the recording only: plan.json lists `refused` instead."""

    checks: int
    first_checks: int | None
    expanded: int
    first_seconds: float | None
    record_seconds: float | None
    refused: Refusals
    proof: Proof | None = None
    events: tuple[SearchStep, ...] = ()
    n_events: int = 0


@dataclass(frozen=True)
class ListingFacts:
    """What the top-k listing adds: the feasibility score (None above the full table's size or
    without a complete sequence), the ground truth's number of orders (None: none given) and
    whether a budget stopped it early."""

    feasibility: float | None
    ground_truth_orders: int | None
    stopped_by_budget: bool


@dataclass(frozen=True)
class Plan:
    """The checked plan of one assembly (module docstring). `planner` holds the planner's name
    ("verified" or "topk") and settings; `sources` what the task adds (checkpoint, assembly
    path, load_seconds); `seconds` the planning's wall time, the model loaded."""

    name: str
    n_parts: int
    planner: dict[str, Any]
    outcome: str
    orders: tuple[PlannedOrder, ...]
    seconds: float
    search: SearchFacts | None = None
    listing: ListingFacts | None = None
    sources: dict[str, Any] = field(default_factory=dict)


def in_truth(truth: GroundTruth | None, order: Sequence[int]) -> bool | None:
    """Whether `order` is one of the ground truth's orders (None: no ground truth given)."""
    if truth is None:
        return None
    state = 0
    for part in order:
        try:
            if not truth.label(state) >> part & 1:
                return False
        except KeyError:
            return False
        state |= 1 << part
    return True


def _blocking(verdict: Any) -> tuple[int, ...]:
    return tuple(sorted({b.part for b in blockers(verdict) if b.part is not None}))


def step_verdicts(check: OrderCheck, names: Sequence[str]) -> StepVerdicts:
    """The per-step verdicts of one checked order, with the failing step's rule and reason."""
    failure = check.failure
    return StepVerdicts(
        feasible=check.feasible,
        verdicts=tuple(v.feasible for v in check.verdicts),
        failing_step=check.failing_step,
        rule=failure.rule if failure else None,
        blocking_parts=_blocking(failure) if failure else (),
        reason=describe(failure, names) if failure else None,
    )


def checked_orders(
    ranked: Sequence[Ranked], checker: OrderChecker, truth: GroundTruth | None
) -> tuple[PlannedOrder, ...]:
    """`ranked` best first, each checked step by step in `checker`'s simulator."""
    names = [p.name for p in checker.assembly.parts]
    return tuple(
        PlannedOrder(
            rank=rank,
            sequence=tuple(r.sequence),
            parts=tuple(names[p] for p in r.sequence),
            probability=r.probability,
            step_scores=tuple(r.step_scores),
            simulator=step_verdicts(checker.check(r.sequence), names),
            ground_truth=in_truth(truth, r.sequence),
        )
        for rank, r in enumerate(ranked, 1)
    )


def listing_plan(
    ranking: Ranking,
    checker: OrderChecker,
    truth: GroundTruth | None,
    planner: dict[str, Any],
    seconds: float,
) -> Plan:
    """The top-k listing's plan: its sequences, each checked afterwards."""
    assembly = checker.assembly
    return Plan(
        name=assembly.name,
        n_parts=assembly.n_parts,
        planner=planner,
        outcome=LISTED,
        orders=checked_orders(ranking.ranked, checker, truth),
        seconds=seconds,
        listing=ListingFacts(
            ranking.feasibility, truth.n_orders() if truth is not None else None, ranking.stopped
        ),
    )


def search_steps(result: SearchResult, checker: OrderChecker, max_events: int) -> list[SearchStep]:
    """The first `max_events` events of a search, each refusal with the simulator's reason."""
    names = [p.name for p in checker.assembly.parts]
    steps = []
    for event in result.events[:max_events]:
        if event.kind == "refused":
            verdict = checker.verdict(event.state, event.part)
            steps.append(
                SearchStep(
                    event.kind, event.state, event.part, event.checks, _blocking(verdict),
                    verdict.rule, describe(verdict, names),
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
    return steps


def refusals(steps: Sequence[SearchStep]) -> Refusals:
    """The refused steps among `steps`: counted, by rule, the first `REFUSALS_LISTED` listed."""
    refused = [s for s in steps if s.kind == "refused"]
    return Refusals(
        count=len(refused),
        by_rule=dict(Counter(s.rule for s in refused).most_common()),
        first=tuple(
            RefusedStep(tuple(mask_to_parts(s.state)), s.part, s.rule, s.blocking, s.reason)
            for s in refused[:REFUSALS_LISTED]
        ),
    )


def proof(part: int, names: Sequence[str]) -> Proof:
    """Why no order can place `part` (grace/planning/precedence.py)."""
    return Proof(
        part=part,
        name=names[part],
        reason=(
            f"no order can place part {part} ({names[part]}): the precedences every order must "
            "keep leave it without a usable option, or force it before itself "
            "(docs/planning.md, 'Infeasibility without a search')"
        ),
    )


def search_plan(
    result: SearchResult,
    checker: OrderChecker,
    truth: GroundTruth | None,
    planner: dict[str, Any],
    record_seconds: float,
    steps: Sequence[SearchStep],
) -> Plan:
    """The verified search's plan: its orders (every step checked), what it cost, the steps it
    saw refused (`steps`: its events with reasons, `search_steps`)."""
    assembly = checker.assembly
    names = [p.name for p in assembly.parts]
    facts = SearchFacts(
        checks=result.checks,
        first_checks=result.first_checks,
        expanded=result.expanded,
        first_seconds=result.first_seconds,
        record_seconds=record_seconds,
        refused=refusals(steps),
        proof=proof(result.unplaceable, names) if result.unplaceable is not None else None,
        events=tuple(steps),
        n_events=len(result.events),
    )
    return Plan(
        name=assembly.name,
        n_parts=assembly.n_parts,
        planner=planner,
        outcome=str(result.outcome),
        orders=checked_orders(result.orders, checker, truth),
        seconds=result.seconds,
        search=facts,
    )
