"""Counts over all thresholds at once, from one set of scored states (paper, Algorithm 1).

Algorithm 1 at λ retrieves exactly the complete paths of the state DAG whose every step scores
≥ λ. Counting those paths (and those that are ground-truth orders) needs no listing: a dynamic
programme over the 2^N states, vectorised over the λ grid, gives |RET| and |RET ∩ REL| for every
λ of the sequence-AUC sweep from the same scores — N! never appears.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from grace.domain.assembly import full_mask
from grace.domain.orders import GroundTruth
from grace.planning.sequences import ScoredStates


@dataclass(frozen=True)
class StateLevel:
    """The state bitmasks of N parts with k placed, and their steps down and up the state DAG.

    Every dynamic programme below walks the DAG one level at a time, each level in a few array
    operations over all its states and parts (pulling from the level before), not one per part:
    at N ≤ 7 a programme's cost is numpy's per-call overhead, so the call count is the cost.
    """

    states: np.ndarray  # (L,) bitmasks with k parts placed, ascending
    placed: np.ndarray  # (L, k) each state's placed parts, ascending
    parents: np.ndarray  # (L, k) the state without each placed part
    unplaced: np.ndarray  # (L, N − k) each state's unplaced parts, ascending
    children: np.ndarray  # (L, N − k) the state plus each unplaced part


@lru_cache(maxsize=32)
def state_levels(n_parts: int) -> list[StateLevel]:
    """The levels of N parts, from the empty state (k = 0) to the complete one (k = N)."""
    states = np.arange(full_mask(n_parts) + 1, dtype=np.int64)
    bits = (states[:, None] >> np.arange(n_parts, dtype=np.int64) & 1).astype(bool)
    count = bits.sum(axis=1)
    levels = []
    for k in range(n_parts + 1):
        level, flags = states[count == k], bits[count == k]
        placed = np.nonzero(flags)[1].reshape(level.size, k)
        unplaced = np.nonzero(~flags)[1].reshape(level.size, n_parts - k)
        levels.append(
            StateLevel(
                states=level,
                placed=placed,
                parents=level[:, None] ^ np.int64(1) << placed,
                unplaced=unplaced,
                children=level[:, None] | np.int64(1) << unplaced,
            )
        )
    return levels


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
    lams = np.asarray(thresholds, dtype=np.float64)
    labels = label_table(truth)
    ret = np.zeros((full_mask(n) + 1, lams.size))
    hit = np.zeros_like(ret)
    ret[0] = hit[0] = 1.0
    for level in state_levels(n)[1:]:
        parents, parts = level.parents, level.placed
        passes = scored.table[parents, parts][..., None] >= lams  # NaN (not scored) never passes
        valid = (labels[parents] >> parts & 1 == 1)[..., None]
        ret[level.states] = (ret[parents] * passes).sum(axis=1)
        hit[level.states] = (hit[parents] * (passes & valid)).sum(axis=1)
    full = full_mask(n)
    return ret[full], hit[full]


def _best_path(scored: ScoredStates, combine, start: float) -> float:
    """Max over complete paths of the steps' scores folded by `combine` (from `start`); −inf when
    no complete path was scored."""
    n = scored.n_parts
    best = np.empty(full_mask(n) + 1)
    best[0] = start
    for level in state_levels(n)[1:]:
        steps = combine(best[level.parents], scored.table[level.parents, level.placed])
        reached = np.fmax.reduce(steps, axis=1)  # NaN (a step not scored) only if every one is
        best[level.states] = np.where(np.isnan(reached), -np.inf, reached)
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
