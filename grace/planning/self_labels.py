"""Training targets from a checked plan: the labels expert iteration (self-training) learns from
(grace/tasks/self_train.py, docs/size-generalisation.md "Self-training").

The verified search (grace/planning/search.py) returns orders whose every step the simulator
accepted, and `Plan` carries each order's step verdicts (grace/planning/plans.py). The labels
are built from those orders only, an order with any refused verdict is dropped: the ground
truth of the label is the DAG the verified orders span (`GroundTruth.from_orders`), so its
states are the states on the verified orders, and in each of them the parts that start a
verified continuation are the valid next parts (label 1) and every other part is 0.

That is a partial label. A refused step in such a state is a true 0 (the simulator refused the
placement there). A part the search never tried, or whose continuation it did not finish, is
labelled 0 too although it may well complete: the search stops at `k` orders, so at a state
with more valid parts than the orders through it, some valid parts are taught as invalid. With
`datamodule.states=reachable` the network also gets no dead-end states of these assemblies (the
search's refused continuations are not in the DAG; the probe below adds some). States off the
verified orders carry no label at all. An assembly the search proved infeasible (every order
refuted by simulator checks, or by the precedences every order keeps) gets the infeasible label
of the data set: its empty state, with no valid part. An assembly the search left "not found
within budget" gets none.

The mask (`plan_labels(..., negatives=)`, `task.mask_unknown`) keeps only what is known: in a
state on the verified orders, the parts that start a verified continuation (1), the parts known
not to (0: the steps the simulator refused there during the search, and those the checks' own
fixation rule refuses, grace/planning/fixation_prior.py, which no order takes) and the placed
parts; every other part carries no loss (`LabelledAssembly.known`). An infeasibility proof
is known for every part.

The probe (`probe_steps`, `task.probe_checks`) decides those unknown parts of the orders'
states with the simulator: a step it finds a verified completion for is valid (its order joins
the label), one whose check refuses it or whose every continuation it refutes is not; the
latter enter the label as the brute force has them, a placeable step into a dead state whose
every label is 0. With `paths` (`task.probe_own_sequence`) it also decides the states on the
policy's own first choice (`own_sequence`, the sequence P@1 judges) as far as that stays
completable, and the step where it leaves: the verified orders hold the states the expert
visits, the policy's mistakes happen in the states it visits itself (DAgger: Ross et al.,
AISTATS 2011).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from grace.domain.assembly import Assembly, full_mask, mask_to_parts
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.planning.fixation_prior import FixationPrior
from grace.planning.plans import Plan
from grace.planning.search import (
    Direction,
    Outcome,
    SearchEvent,
    SearchResult,
    VerifiedSearch,
)
from grace.planning.sequences import Scorer, score_states
from grace.planning.step_checks import StepOracle
from grace.planning.topk import completion_bounds, lazy_scores, table_scores, top_k

Negatives = Callable[[int], int]
"""`negatives(state)`: the parts known not to be a valid next step in `state` (a bitmask)."""

VERIFIED_LABELS = "verified"
"""`info["labels"]` of a self-labelled assembly (the brute-forced ones say "brute_force")."""


def verified_orders(plan: Plan) -> list[tuple[int, ...]]:
    """The plan's orders whose every step the simulator accepted."""
    return [
        order.sequence
        for order in plan.orders
        if order.simulator.feasible and len(order.simulator.verdicts) == plan.n_parts
    ]


def add_refusals(events: Iterable[SearchEvent], into: dict[int, int]) -> dict[int, int]:
    """`into`, per state, with the parts a search's `events` saw the simulator refuse there."""
    for event in events:
        if event.kind == "refused":
            into[event.state] = into.get(event.state, 0) | 1 << event.part
    return into


def search_negatives(result: SearchResult, prior: FixationPrior) -> Negatives:
    """The steps `result`'s search saw the simulator refuse, and those the exact fixation
    `prior` (`FixationPrior.of_steps`) refuses: a refused placement is no valid next step, and
    the prior refuses only steps no order takes."""
    refused = add_refusals(result.events, {})
    full = full_mask(len(prior.enablers))

    def negatives(state: int) -> int:
        unplaced = full & ~state
        barred = sum(1 << p for p in mask_to_parts(unplaced) if not prior.allows(state, p))
        return (refused.get(state, 0) | barred) & unplaced

    return negatives


@dataclass
class Probe:
    """What `probe_steps` learnt: `orders`, one new verified order per step found to start a
    verified continuation; `dead_ends`, one partial order per step found to start none although
    its check accepts it (a verified prefix, then that step, into a state proved dead);
    `refused`, per state, the steps the probe saw refused; `open_steps`, the steps left unknown
    (their sub-search ran out of checks); `checks`, the step checks asked."""

    orders: list[tuple[int, ...]] = field(default_factory=list)
    dead_ends: list[tuple[int, ...]] = field(default_factory=list)
    refused: dict[int, int] = field(default_factory=dict)
    open_steps: int = 0
    checks: int = 0

    def negatives(self, also: Negatives) -> Negatives:
        """`also` and what the probe proved: the steps it saw refused and those into dead
        states."""
        into_dead: dict[int, int] = {}
        for *prefix, part in self.dead_ends:
            before = sum(1 << p for p in prefix)
            into_dead[before] = into_dead.get(before, 0) | 1 << part
        return lambda s: also(s) | self.refused.get(s, 0) | into_dead.get(s, 0)


def own_sequence(scorer: Scorer, assembly: Assembly, threshold: float) -> tuple[int, ...]:
    """The policy's first choice: its most probable sequence whose every step scores ≥ λ
    (Algorithm 1's top one, the sequence strict P@1 judges), or, when none passes λ, its
    greedy path (the highest-scoring unplaced part in each state), which runs through the state
    where its scores fell below λ."""
    n = assembly.n_parts
    scored = score_states(scorer, assembly, threshold)
    bounds = completion_bounds(scored, threshold)
    best, _ = top_k(table_scores(scored), n, 1, threshold, bounds)
    if best:
        return best[0].sequence
    scores, state, path = lazy_scores(scorer, assembly), 0, []
    for _ in range(n):
        row = np.where([not state >> p & 1 for p in range(n)], scores(state), -np.inf)
        path.append(int(np.argmax(row)))
        state |= 1 << path[-1]
    return tuple(path)


def probe_steps(
    orders: list[tuple[int, ...]],
    negatives: Negatives,
    steps: StepOracle,
    prior: FixationPrior,
    budget: int,
    paths: Sequence[tuple[int, ...]] = (),
) -> Probe:
    """Decide the unknown steps out of the states on `orders` (the verified orders): for each
    state and each part that neither starts one of them nor is in `negatives(state)`, check
    the step, and if the check accepts it, search forward from the state after it for one
    verified completion (`VerifiedSearch.search(start=)`, at most `budget` checks): found, the
    step is valid (its order is added); proved impossible, the step leads into a dead end;
    neither, it stays unknown. The question is feasibility, not preference, so the sub-search
    needs no policy: it tries parts in index order and backjumps on what it learns. Cost: at
    most 1 + `budget` checks per unknown step of the states on the orders, where the brute
    force decides every reachable state.

    Then each of `paths` (complete sequences, e.g. `own_sequence`) is walked from the empty
    state: every state on it is decided the same way, up to the first step not proved valid
    (refused, into a dead end, or left open), whose state is the last one decided."""
    n = steps.n_parts
    uniform = np.full(n, 0.5)
    full = full_mask(n)
    truth = GroundTruth.from_orders(n, orders)
    valid = dict(zip(truth.states.tolist(), truth.completable.tolist(), strict=True))
    reach: dict[int, tuple[int, ...]] = {0: ()}  # a verified prefix to each decided state
    for order in orders:
        state = 0
        for i, part in enumerate(order, 1):
            state |= 1 << part
            reach.setdefault(state, tuple(order[:i]))
    search = VerifiedSearch(k=1, direction=Direction.forward)
    probe, first = Probe(), steps.checks

    def decide(state: int) -> None:
        for part in mask_to_parts(full & ~state & ~valid.get(state, 0) & ~negatives(state)):
            bit = 1 << part
            if not steps.check(state, part).feasible:
                probe.refused[state] = probe.refused.get(state, 0) | bit
                continue
            if state | bit == full:  # the last step: accepted, it completes an order
                probe.orders.append((*reach[state], part))
                valid[state] = valid.get(state, 0) | bit
                continue
            budgeted = replace(search, max_checks=steps.checks + budget)
            result = budgeted.search(
                lambda _: uniform, steps, prior.allows, prior_proves=True, start=state | bit
            )
            add_refusals(result.events, probe.refused)
            if result.outcome == Outcome.verified:
                probe.orders.append((*reach[state], part, *result.orders[0].sequence))
                valid[state] = valid.get(state, 0) | bit
            elif result.outcome == Outcome.infeasible:
                probe.dead_ends.append((*reach[state], part))
            else:
                probe.open_steps += 1

    decided = set(truth.states.tolist())
    for state in truth.states.tolist():
        decide(state)
    for path in paths if orders else ():
        state = 0
        for part in path:
            if state not in decided:
                decided.add(state)
                decide(state)
            if not valid.get(state, 0) >> part & 1:
                break
            reach.setdefault(state | 1 << part, (*reach[state], part))
            state |= 1 << part
    probe.checks = steps.checks - first
    return probe


def plan_labels(
    plan: Plan,
    assembly: Assembly,
    negatives: Negatives | None = None,
    probed: Probe | None = None,
) -> LabelledAssembly | None:
    """`assembly` labelled from its verified search's `plan` (module docstring), or None when
    the plan has neither a verified order nor a proof of infeasibility. With `negatives`, the
    label of a state covers only its verified valid parts, `negatives(state)` and its placed
    parts (`LabelledAssembly.known`); without, every part's label counts. `probed`
    (`probe_steps`) adds its orders, its dead ends (as the brute force labels them: the step in
    is placeable but not valid, every label of the dead state is 0 and known) and, to
    `negatives`, what it proved."""
    if plan.n_parts != assembly.n_parts:
        raise ValueError(f"a plan of {plan.n_parts} parts for {assembly.n_parts} ({plan.name})")
    orders, dead_ends = verified_orders(plan), []
    if probed is not None:
        orders, dead_ends = orders + probed.orders, probed.dead_ends
        negatives = None if negatives is None else probed.negatives(negatives)
    info = {"labels": VERIFIED_LABELS, "outcome": plan.outcome, "verified_orders": len(orders)}
    if plan.search is not None:
        info |= {"checks": plan.search.checks, "refused": plan.search.refused.count}
    if probed is not None:
        info |= {
            "probe_orders": len(probed.orders),
            "probe_checks": probed.checks,
            "probe_open_steps": probed.open_steps,
        }
    if orders:
        truth = GroundTruth.from_orders(assembly.n_parts, orders, dead_ends)
        known = None
        if negatives is not None:
            full = full_mask(assembly.n_parts)
            # a state no verified order continues from is the complete one or proved dead
            known = {
                int(s): int(s) | int(c) | negatives(int(s)) if c else full
                for s, c in zip(truth.states, truth.completable, strict=True)
            }
            open_parts = [(full & ~s).bit_count() for s in known]
            told = [(k & ~s).bit_count() for s, k in known.items()]
            info["known_share"] = sum(told) / max(1, sum(open_parts))
        return LabelledAssembly(assembly, truth, info, known)
    if plan.outcome == Outcome.infeasible:
        return LabelledAssembly(assembly, GroundTruth.from_orders(assembly.n_parts, []), info)
    return None
