"""Baseline policies, scored by the same planner and metrics as GRACE (issue 4)."""

from __future__ import annotations

import numpy as np

from grace.domain.assembly import Assembly
from grace.planning.sequences import Scorer, unplaced


def random_scorer(seed: int) -> Scorer:
    """A policy that scores every unplaced part uniformly at random in [0, 1) (placed parts 0).

    It knows the rules of the game (never re-place a part) and nothing about the geometry, so the
    gap between it and GRACE is what learning adds. Seeded: the same calls give the same scores.
    """
    rng = np.random.default_rng(seed)

    def scorer(assembly: Assembly, states: np.ndarray) -> np.ndarray:
        states = np.asarray(states, dtype=np.int64)
        scores = rng.random((len(states), assembly.n_parts))
        return np.where(unplaced(states, assembly.n_parts), scores, 0.0)

    return scorer


BASELINES = {"random": random_scorer}
"""Baseline policies by name (`task.baselines`), each built from a seed."""
