"""A geometric policy that needs no learning: the baseline the network must beat in the search.

It scores from the contact graph alone (which parts touch, within the cell's touch tolerance),
with two facts of the world (docs/world.md) and no training:
- fixation: a profile goes first; a later profile needs a placed part it touches, a bracket a
  placed profile it joins. Steps fixation allows score ≥ 0.5, the others < 0.5;
- obstacles only accumulate: the more of a part's neighbours are placed, the less room is left
  for its fingers, its palm and its slide into its joints, so among the allowed steps a part
  scores by a weighted count of its placed neighbours (`placed_weight`, "touching the most
  placed parts first") and of its unplaced ones (`unplaced_weight`, "hosts first": a part that
  many others will stand on goes while its grasps are free).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import Assembly
from grace.planning.sequences import Scorer
from grace.simulation.joints import touching


@dataclass(frozen=True)
class ContactHeuristic:
    """Weights of the contact counts (module docstring); `tolerance` is the touch tolerance in
    mm (the cell's `touch_tolerance`)."""

    placed_weight: float = 1.0
    unplaced_weight: float = 0.0
    tolerance: float = 0.5

    def scorer(self) -> Scorer:
        """`scorer(assembly, states)` with the contact graph computed once per assembly."""
        cache: dict[int, tuple[Assembly, np.ndarray, np.ndarray]] = {}

        def scores(assembly: Assembly, states: np.ndarray) -> np.ndarray:
            hit = cache.get(id(assembly))
            if hit is None or hit[0] is not assembly:
                touch = touching(assembly, self.tolerance).astype(np.float64)
                profiles = np.array([p.type.is_profile for p in assembly.parts])
                cache.clear()
                hit = cache[id(assembly)] = (assembly, touch, profiles)
            _, touch, profiles = hit
            return self._scores(touch, profiles, np.asarray(states, dtype=np.int64))

        return scores

    def _scores(self, touch: np.ndarray, profiles: np.ndarray, states: np.ndarray) -> np.ndarray:
        n = len(profiles)
        placed = (states[:, None] >> np.arange(n) & 1).astype(np.float64)  # (S, N)
        near_placed = placed @ touch  # placed neighbours per part
        near_profile = placed @ (touch * profiles[:, None])  # placed profiles it touches
        near_unplaced = touch.sum(axis=0) - near_placed
        empty = (states == 0)[:, None]
        fixed = np.where(profiles, empty | (near_placed > 0), ~empty & (near_profile > 0))
        weights = np.array([self.placed_weight, self.unplaced_weight])
        raw = weights[0] * near_placed + weights[1] * near_unplaced
        low = np.minimum(weights, 0).sum() * (n - 1)  # the range raw can take
        high = np.maximum(weights, 0).sum() * (n - 1)
        return np.where(placed > 0, 0.0, (fixed + (raw - low) / (high - low + 1.0)) / 2.0)
