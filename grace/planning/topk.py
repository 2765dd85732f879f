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
from grace.planning.sequences import ScoredStates, Scorer

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
