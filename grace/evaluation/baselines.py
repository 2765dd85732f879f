"""Baseline policies and floors, scored by the same planner and metrics as GRACE.

A metric reads honestly only beside what a policy that knows nothing gets (docs/metrics.md):

- `random`: every unplaced part scores uniformly at random; the gap to GRACE is what learning adds;
- `constant`: every unplaced part scores 0.5, so Algorithm 1 at λ ≤ 0.5 retrieves all N! orders
  and above it none; its sequence AUC is (1 + mean IR precision of "everything") / 2, above 0.5;
  P@k ranks its tied sequences in a seeded random order (grace.evaluation.evaluate.tie_order),
  so its P@1 is that of a random order, not of the part numbering;
- `never`: scores below every threshold, so Algorithm 1 retrieves nothing at any λ: sequence AUC
  exactly 0.5 (recall 0, precision 1 by the empty-retrieval rule), paper P@k 1, strict P@k 0.

`random` and `constant` know the rules of the game (placed parts score 0) and nothing about the
geometry.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from grace.domain.assembly import Assembly
from grace.planning.sequences import Scorer, unplaced

NEVER = -1.0
"""The `never` policy's score: below every λ ≥ 0, so no branch of Algorithm 1 is ever taken. Not a
probability; the step AUC only ranks scores."""


def random_scorer(seed: int) -> Scorer:
    """Unplaced parts uniformly at random in [0, 1), placed parts 0; seeded (same calls, same
    scores)."""
    rng = np.random.default_rng(seed)

    def scorer(assembly: Assembly, states: np.ndarray) -> np.ndarray:
        states = np.asarray(states, dtype=np.int64)
        scores = rng.random((len(states), assembly.n_parts))
        return np.where(unplaced(states, assembly.n_parts), scores, 0.0)

    return scorer


def constant_scorer(seed: int) -> Scorer:
    """Unplaced parts 0.5, placed parts 0 (`seed` is unused: the policy is deterministic)."""

    def scorer(assembly: Assembly, states: np.ndarray) -> np.ndarray:
        return np.where(unplaced(np.asarray(states), assembly.n_parts), 0.5, 0.0)

    return scorer


def never_scorer(seed: int) -> Scorer:
    """Every part NEVER (`seed` is unused): the policy that never retrieves a sequence."""

    def scorer(assembly: Assembly, states: np.ndarray) -> np.ndarray:
        return np.full((len(states), assembly.n_parts), NEVER)

    return scorer


BASELINES: dict[str, Callable[[int], Scorer]] = {
    "random": random_scorer,
    "constant": constant_scorer,
    "never": never_scorer,
}
"""Baseline policies by name (`task.baselines`), each built from a seed."""
