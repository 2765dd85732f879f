"""Top-k mode of Algorithm 1: the k most probable complete sequences without listing N! of them.

Step scores are ≤ 1, so a prefix's probability bounds that of every completion: best-first
search on prefix probability pops complete sequences in descending probability (ties broken
lexicographically, as a full listing sorted by (−probability, sequence) would). States are scored
lazily and once each, so for N ≥ 9 only the states near the best sequences are ever evaluated.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import Assembly, full_mask
from grace.planning.counting import bottleneck
from grace.planning.sequences import ScoredStates, Scorer, score_states

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


def top_k(scores: StateScores, n_parts: int, k: int, threshold: float) -> list[Ranked]:
    """The k most probable complete sequences with every step score ≥ `threshold`."""
    full = full_mask(n_parts)
    heap: list[tuple[float, tuple[int, ...], int, tuple[float, ...]]] = [(-1.0, (), 0, ())]
    out: list[Ranked] = []
    while heap and len(out) < k:
        neg_prob, prefix, state, steps = heapq.heappop(heap)
        if state == full:
            out.append(Ranked(prefix, -neg_prob, steps))
            continue
        row = scores(state)
        for part in range(n_parts):
            if state >> part & 1 or not row[part] >= threshold:
                continue
            step = float(row[part])
            heapq.heappush(
                heap, (neg_prob * step, (*prefix, part), state | 1 << part, (*steps, step))
            )
    return out


FULL_TABLE_MAX_PARTS = 14
"""Up to this size every state is scored (2^N − 1 ≤ 16,383, one batched call per level) and the
feasibility score is exact; above it only the states best-first search visits are scored."""


@dataclass(frozen=True)
class Ranking:
    """The best complete sequences of one assembly under a policy.

    `feasibility` is the bottleneck score (the largest λ at which Algorithm 1 still finds a
    complete sequence, docs/metrics.md), None above `FULL_TABLE_MAX_PARTS` parts; `scores`
    gives any state's part scores (from the table, or scored on demand).
    """

    ranked: list[Ranked]
    feasibility: float | None
    scores: StateScores
    passes: int


def rank_sequences(scorer: Scorer, assembly: Assembly, k: int, threshold: float = 0.0) -> Ranking:
    """The `k` most probable complete sequences with every step ≥ `threshold`, best first."""
    n = assembly.n_parts
    if n <= FULL_TABLE_MAX_PARTS:
        scored = score_states(scorer, assembly, threshold=0.0)
        scores = table_scores(scored)
        ranked = top_k(scores, n, k, threshold)
        return Ranking(ranked, bottleneck(scored), scores, scored.passes)
    lazy = lazy_scores(scorer, assembly)
    ranked = top_k(lazy, n, k, threshold)
    return Ranking(ranked, None, lazy, len(lazy.cache))  # type: ignore[attr-defined]
