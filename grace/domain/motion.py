"""Insertion motions: how a part travels to its final pose (simulator and planner-side views)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Motion:
    """A polyline of part positions relative to the final pose, start first, final pose last.

    `waypoints` is a (K, 3) array of translation offsets in world mm; the part keeps its final
    orientation throughout. A top-down placement is [(0, 0, h), (0, 0, 0)]; a slide is lowered
    `travel` mm back along its direction, then slides into place:
    [(−d·t, h), (−d·t, 0), (0, 0, 0)] for slide direction d and travel t. The first waypoint's
    height h is where the part was carried in at; a descent may pass stops at lower carry
    heights, [(0, 0, h₂), (0, 0, h₁), (0, 0, 0)], which leave the path as it is.
    `kind` is "top_down", "slide" (along the part's own axis) or "side_slide" (a stem along its
    hosts' grooves, across its own axis); `direction` the unit slide direction, if any.
    `joint_blockers` is the bitmask of parts whose T-slot connection with this part the motion
    cannot make once they are placed (docs/world.md, rule "joints").
    """

    kind: str
    waypoints: np.ndarray
    direction: tuple[float, float] | None = None
    joint_blockers: int = 0

    @property
    def travel(self) -> float:
        """Horizontal length of the motion (0 for a top-down placement)."""
        return float(np.hypot(*np.asarray(self.waypoints[0][:2], dtype=float)))

    def segments(self) -> list[tuple[np.ndarray, np.ndarray]]:
        w = np.asarray(self.waypoints, dtype=float)
        return [(w[i], w[i + 1]) for i in range(len(w) - 1)]
