"""Counts over all thresholds at once, from one set of scored states (paper, Algorithm 1).

Algorithm 1 at λ retrieves exactly the complete paths of the state DAG whose every step scores
≥ λ. Counting those paths (and those that are ground-truth orders) needs no listing: a dynamic
programme over the 2^N states, vectorised over the λ grid, gives |RET| and |RET ∩ REL| for every
λ of the sequence-AUC sweep from the same scores — N! never appears.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from grace.domain.assembly import full_mask
from grace.domain.orders import GroundTruth
from grace.planning.sequences import ScoredStates


@lru_cache(maxsize=32)
def state_levels(n_parts: int) -> list[np.ndarray]:
    """Non-complete state bitmasks of N parts grouped by how many parts are placed (0 … N−1)."""
    states = np.arange(full_mask(n_parts) + 1, dtype=np.int64)
    popcount = np.array([int(s).bit_count() for s in states])
    return [states[popcount == k] for k in range(n_parts)]


def label_table(truth: GroundTruth) -> np.ndarray:
    """Next-step label mask of every state bitmask (0 for states off every feasible order)."""
    table = np.zeros(full_mask(truth.n_parts) + 1, dtype=np.int64)
    table[truth.states] = truth.completable
    return table


def retrieval_counts(
    scored: ScoredStates, truth: GroundTruth, thresholds: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(|RET|, |RET ∩ REL|) per threshold: retrieved complete sequences and ground-truth ones."""
    if np.min(thresholds) < scored.threshold:
        raise ValueError(
            f"thresholds go down to {np.min(thresholds)} but the states were scored for "
            f"λ ≥ {scored.threshold}: score with threshold 0 for a full sweep"
        )
    n = scored.n_parts
    lams = np.asarray(thresholds, dtype=np.float64)[None, :]
    labels = label_table(truth)
    ret = np.zeros((full_mask(n) + 1, lams.size))
    hit = np.zeros_like(ret)
    ret[0] = hit[0] = 1.0
    for level in state_levels(n):
        level = level[ret[level].any(axis=1)]
        for part in range(n):
            states = level[(level >> part & 1) == 0]
            passes = scored.table[states, part][:, None] >= lams
            valid = ((labels[states] >> part & 1) == 1)[:, None]
            child = states | (np.int64(1) << part)
            ret[child] += ret[states] * passes
            hit[child] += hit[states] * (passes & valid)
    full = full_mask(n)
    return ret[full], hit[full]


def _best_path(scored: ScoredStates, combine, start: float) -> float:
    """Max over complete paths of the steps' scores folded by `combine` (from `start`)."""
    n = scored.n_parts
    best = np.full(full_mask(n) + 1, -np.inf)
    best[0] = start
    for level in state_levels(n):
        for part in range(n):
            states = level[(level >> part & 1) == 0]
            step = combine(best[states], scored.table[states, part])
            child = states | (np.int64(1) << part)
            best[child] = np.maximum(best[child], np.nan_to_num(step, nan=-np.inf))
    return float(best[full_mask(n)])


def bottleneck(scored: ScoredStates) -> float:
    """Largest λ at which Algorithm 1 still finds a complete sequence (max over paths of min step).

    Thresholding it at λ is exactly "some complete sequence found at λ": the feasibility score.
    """
    return _best_path(scored, np.minimum, np.inf)


def best_probability(scored: ScoredStates) -> float:
    """Probability of the most probable complete sequence (max over paths of the product of
    step scores): the first sequence top-k returns at λ = 0, found without listing any."""
    return _best_path(scored, np.multiply, 1.0)
