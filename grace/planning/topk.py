"""Top-k mode of Algorithm 1: the k most probable complete sequences without listing N! of them.

Step scores are ≤ 1, so a prefix's probability bounds that of every completion: best-first
search on prefix probability pops complete sequences in descending probability (ties broken
lexicographically, as a full listing sorted by (−probability, sequence) would). States are scored
lazily and once each, so for N ≥ 9 only the states near the best sequences are ever evaluated.
"""

from __future__ import annotations

import heapq
import logging
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace

import numpy as np

from grace.domain.assembly import Assembly, full_mask
from grace.domain.orders import GroundTruth
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.counting import bottleneck, state_levels
from grace.planning.plans import Plan, listing_plan
from grace.planning.sequences import ScoredStates, Scorer, score_states

log = logging.getLogger(__name__)

StateScores = Callable[[int], np.ndarray]
"""`scores(state)`: the N part scores of one state bitmask."""


@dataclass(frozen=True)
class Ranked:
    """One complete sequence with its probability and step scores."""

    sequence: tuple[int, ...]
    probability: float
    step_scores: tuple[float, ...]


def lazy_scores(scorer: Scorer, assembly: Assembly) -> StateScores:
    """Scores of single states on demand, each state scored at most once."""
    cache: dict[int, np.ndarray] = {}

    def scores(state: int) -> np.ndarray:
        if state not in cache:
            batch = np.array([state], dtype=np.int64)
            cache[state] = np.asarray(scorer(assembly, batch), dtype=np.float64)[0]
        return cache[state]

    scores.cache = cache  # type: ignore[attr-defined]
    return scores


def table_scores(scored: ScoredStates) -> StateScores:
    """State scores read from an already scored table (no forward passes)."""
    return lambda state: scored.table[state]


def completion_bounds(scored: ScoredStates, threshold: float) -> np.ndarray:
    """Per state bitmask, the largest product of step scores over its completions whose every
    step scores ≥ `threshold` (0 where there is none; 1 for the full state).

    The exact probability still to come: with it best-first search (A*) walks straight to the
    next best complete sequence. Without it, near-uniform scores (an uncertain model, a large
    assembly) make plain best-first search expand almost every prefix before the first
    complete one, N! of them at worst.
    """
    n = scored.n_parts
    best = np.zeros(full_mask(n) + 1)
    best[full_mask(n)] = 1.0
    for level in reversed(state_levels(n)[:-1]):
        step = scored.table[level.states[:, None], level.unplaced]
        step = np.where(step >= threshold, step, 0.0)  # NaN (not scored) never passes
        best[level.states] = (step * best[level.children]).max(axis=1)
    return best


def top_k(
    scores: StateScores,
    n_parts: int,
    k: int,
    threshold: float,
    bounds: np.ndarray | None = None,
    max_expansions: int | None = None,
    max_seconds: float | None = None,
    tie_order: np.ndarray | None = None,
) -> tuple[list[Ranked], bool]:
    """The k most probable complete sequences with every step score ≥ `threshold`, and whether
    a budget stopped the search before it found k (or proved there are fewer).

    `bounds` (completion_bounds of the same scores and threshold) turns the search into A*:
    the same sequences, each found after O(N²) expansions; ties of equal probability may then
    come out in another order than the lexicographic one. Without bounds, near-uniform scores
    can make the search expand up to N! prefixes: `max_expansions` and `max_seconds` (each
    expansion scores a state, a few ms at 20 parts) stop it there, with the sequences found so
    far (maybe none).

    Ties of equal priority go to the prefix first in lexicographic order of the parts' ranks
    `tie_order[part]` (default: the part numbers). A policy of equal scores (the `constant`
    floor) returns the identity order first under the default, which is no neutral choice when
    the numbering means something (generated parts are numbered by distance from the origin);
    a random permutation makes its first sequence a uniformly random order.
    """
    full = full_mask(n_parts)
    start = 1.0 if bounds is None else float(bounds[0])
    rank = np.arange(n_parts) if tie_order is None else np.asarray(tie_order)
    heap: list[tuple[float, tuple[int, ...], tuple[int, ...], int, tuple[float, ...], float]] = [
        (-start, (), (), 0, (), 1.0)
    ]
    out: list[Ranked] = []
    expansions = 0
    deadline = math.inf if max_seconds is None else time.perf_counter() + max_seconds
    while heap and len(out) < k:
        _, ranks, prefix, state, steps, prob = heapq.heappop(heap)
        if state == full:
            out.append(Ranked(prefix, prob, steps))
            continue
        expansions += 1
        if (max_expansions is not None and expansions > max_expansions) or (
            time.perf_counter() > deadline
        ):
            return out, True
        row = scores(state)
        for part in range(n_parts):
            if state >> part & 1 or not row[part] >= threshold:
                continue
            step = float(row[part])
            child = state | 1 << part
            rest = 1.0 if bounds is None else float(bounds[child])
            if bounds is not None and rest <= 0.0:
                continue  # no completion passes λ from here
            priority = -(prob * step) * rest
            heapq.heappush(
                heap,
                (
                    priority,
                    (*ranks, int(rank[part])),
                    (*prefix, part),
                    child,
                    (*steps, step),
                    prob * step,
                ),
            )
    return out, False


@dataclass(frozen=True)
class TopKListing:
    """`planner=topk` (grace/conf/planner/topk.yaml): list the `k` most probable complete
    sequences whose every step scores ≥ `threshold`, unverified (`rank_sequences`)."""

    k: int = 10
    threshold: float = 0.0
    max_expansions: int | None = None
    max_seconds: float | None = None

    def checked_plan(
        self,
        scorer: Scorer,
        assembly: Assembly,
        steps: SimulatorSteps,
        truth: GroundTruth | None = None,
    ) -> Plan:
        """List the sequences, then check each step by step in `steps`' simulator (the listing
        trusts the scores; the checks tell which sequences the robot can execute)."""
        if assembly.n_parts > FULL_TABLE_MAX_PARTS:
            log.warning(
                "%d parts: the top-k listing scores states lazily without completion bounds and "
                "stops at planner.max_expansions=%s, planner.max_seconds=%s; planner=verified is "
                "the bounded planner", assembly.n_parts, self.max_expansions, self.max_seconds,
            )  # fmt: skip
        start = time.perf_counter()
        ranking = rank_sequences(
            scorer, assembly, self.k, self.threshold, self.max_expansions, self.max_seconds
        )
        plan = listing_plan(ranking, steps.checker, truth, {"name": "topk", **asdict(self)}, 0.0)
        return replace(plan, seconds=time.perf_counter() - start)


FULL_TABLE_MAX_PARTS = 14
"""Up to this size every state is scored (2^N − 1 ≤ 16,383, one batched call per level) and the
feasibility score is exact; above it only the states best-first search visits are scored."""


@dataclass(frozen=True)
class Ranking:
    """The best complete sequences of one assembly under a policy.

    `feasibility` is the bottleneck score (the largest λ at which Algorithm 1 still finds a
    complete sequence, docs/metrics.md), None above `FULL_TABLE_MAX_PARTS` parts; `scores`
    gives any state's part scores (from the table, or scored on demand); `stopped`: a budget
    ended the search before it had `k` sequences or had shown that there are fewer.
    """

    ranked: list[Ranked]
    feasibility: float | None
    scores: StateScores
    passes: int
    stopped: bool = False


def rank_sequences(
    scorer: Scorer,
    assembly: Assembly,
    k: int,
    threshold: float = 0.0,
    max_expansions: int | None = None,
    max_seconds: float | None = None,
) -> Ranking:
    """The `k` most probable complete sequences with every step ≥ `threshold`, best first.

    Above `FULL_TABLE_MAX_PARTS` parts the best-first search has no completion bounds:
    `max_expansions` and `max_seconds` cap it (see `top_k`)."""
    n = assembly.n_parts
    if n <= FULL_TABLE_MAX_PARTS:
        scored = score_states(scorer, assembly, threshold=0.0)
        scores = table_scores(scored)
        ranked, _ = top_k(scores, n, k, threshold, completion_bounds(scored, threshold))
        return Ranking(ranked, bottleneck(scored), scores, scored.passes)
    lazy = lazy_scores(scorer, assembly)
    ranked, stopped = top_k(
        lazy, n, k, threshold, max_expansions=max_expansions, max_seconds=max_seconds
    )
    return Ranking(ranked, None, lazy, len(lazy.cache), stopped)  # type: ignore[attr-defined]
