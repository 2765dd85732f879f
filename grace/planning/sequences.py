"""Algorithm 1 of the paper (Sec. IV-C.3) over distinct states instead of prefixes.

The reference traversal runs one forward pass per prefix of the state tree (8,660 for N = 7).
A state is a set, so its scores do not depend on the order that reached it: we score each
reachable state once, level by level in one batched call per level (≤ 2^N − 1 states), and
then expand all prefixes of a level at once with array operations. Sequences come out in the
reference's order (lexicographic: parts are tried in ascending index) and probabilities are
multiplied left to right exactly as the recursion does, so both agree bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import Assembly, full_mask

Scorer = Callable[[Assembly, np.ndarray], np.ndarray]
"""`scorer(assembly, states)`: per-part next-step scores, shape (len(states), N); in [0, 1] for a
policy (a floor baseline may score below 0 to never pass a threshold)."""


@dataclass(eq=False)
class ScoredStates:
    """Scores of the states reachable under a threshold, one forward pass per state.

    `table[s]` holds the N part scores of state bitmask `s` (NaN where `s` was not scored);
    `threshold` is the λ the reachability was computed for: planning at λ ≥ it is exact.
    """

    n_parts: int
    table: np.ndarray
    threshold: float
    passes: int

    def scored(self) -> np.ndarray:
        """Bitmasks of the scored states, ascending."""
        return np.flatnonzero(~np.isnan(self.table[:, 0])).astype(np.int64)


def unplaced(states: np.ndarray, n_parts: int) -> np.ndarray:
    """Boolean (len(states), N) mask of the parts not yet placed in each state."""
    bits = np.int64(1) << np.arange(n_parts, dtype=np.int64)
    return (np.asarray(states, dtype=np.int64)[:, None] & bits) == 0


def _branches(
    table: np.ndarray, states: np.ndarray, threshold: float
) -> tuple[np.ndarray, np.ndarray]:
    """(row, part) pairs of every unplaced part with score ≥ λ, row-major (ascending parts)."""
    n_parts = table.shape[1]
    scores = table[states]
    allowed = unplaced(states, n_parts) & (scores >= threshold)
    return np.nonzero(allowed)


def score_states(scorer: Scorer, assembly: Assembly, threshold: float = 0.0) -> ScoredStates:
    """Score every non-complete state reachable from the empty one through parts scoring ≥ λ.

    One batched scorer call per level; at λ = 0 that is all 2^N − 1 non-complete states.
    """
    n = assembly.n_parts
    full = full_mask(n)
    table = np.full((full + 1, n), np.nan)
    frontier = np.zeros(1, dtype=np.int64)
    passes = 0
    while frontier.size:
        scores = np.asarray(scorer(assembly, frontier), dtype=np.float64)
        if scores.shape != (frontier.size, n):
            raise ValueError(
                f"scorer returned shape {scores.shape}, expected {(frontier.size, n)}: "
                "a Scorer must return one score per part for every state"
            )
        table[frontier] = scores
        passes += frontier.size
        rows, parts = _branches(table, frontier, threshold)
        children = np.unique(frontier[rows] | (np.int64(1) << parts.astype(np.int64)))
        frontier = children[children != full]
    return ScoredStates(n_parts=n, table=table, threshold=threshold, passes=passes)


@dataclass(eq=False)
class Plan:
    """Output of Algorithm 1 at one λ.

    `sequences[i]` is a complete order (part indices), `step_scores[i]` the score of each of its
    steps and `probabilities[i]` their product; `dead_ends` the prefixes that reached a state with
    no part scoring ≥ λ (the empty prefix when already the first step fails).
    """

    sequences: np.ndarray
    step_scores: np.ndarray
    probabilities: np.ndarray
    dead_ends: list[tuple[int, ...]]

    def __len__(self) -> int:
        return len(self.sequences)


def plan(scored: ScoredStates, threshold: float) -> Plan:
    """Every complete sequence whose step scores are all ≥ `threshold` (paper, Algorithm 1)."""
    if threshold < scored.threshold:
        raise ValueError(
            f"threshold {threshold} is below the λ = {scored.threshold} the states were scored "
            "for: call score_states with a threshold ≤ the lowest λ you plan with"
        )
    n = scored.n_parts
    prefixes = np.zeros((1, 0), dtype=np.int64)
    steps = np.zeros((1, 0))
    probs = np.ones(1)
    states = np.zeros(1, dtype=np.int64)
    dead_ends: list[tuple[int, ...]] = []
    for _ in range(n):
        rows, parts = _branches(scored.table, states, threshold)
        stuck = np.setdiff1d(np.arange(len(states)), rows)
        dead_ends.extend(tuple(int(p) for p in prefixes[i]) for i in stuck)
        step = scored.table[states[rows], parts]
        prefixes = np.column_stack([prefixes[rows], parts])
        steps = np.column_stack([steps[rows], step])
        probs = probs[rows] * step
        states = states[rows] | (np.int64(1) << parts.astype(np.int64))
    return Plan(sequences=prefixes, step_scores=steps, probabilities=probs, dead_ends=dead_ends)
