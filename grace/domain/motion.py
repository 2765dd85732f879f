"""Insertion motions: how a part travels to its final pose (simulator and planner-side views)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Motion:
    """A polyline of part positions relative to the final pose, start first, final pose last.

    `waypoints` is a (K, 3) array of translation offsets in world mm; the part keeps its final
    orientation throughout. A top-down placement is [(0, 0, h), (0, 0, 0)]; a T-slot insertion
    is lowered at an offset back along the part's axis, then slides horizontally into the joint:
    [(−d·s, 0, h), (−d·s, 0, 0), (0, 0, 0)] for slide direction d and slide length s.
    `kind` is "top_down" or "slide"; `direction` the unit slide direction in the plane, if any.
    """

    kind: str
    waypoints: np.ndarray
    direction: tuple[float, float] | None = None

    def segments(self) -> list[tuple[np.ndarray, np.ndarray]]:
        w = np.asarray(self.waypoints, dtype=float)
        return [(w[i], w[i + 1]) for i in range(len(w) - 1)]
