"""Grasp candidates and the volumes swept by the gripper and the held part (docs/world.md).

Everything here is world-axis-aligned 3-D boxes in mm, as (lo, hi) corner pairs: parts lie at
multiples of 90°, the gripper comes top-down with its fingers on two parallel faces, and motions
move along world axes. A box translating along a segment then sweeps exactly the box spanning its
start and end copies (for a segment off the axes that box is a conservative hull).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import BRACKET_LEG_MM, BRACKET_THICKNESS_MM, PROFILE_SECTION_MM, Part
from grace.domain.motion import Motion
from grace.simulation.cell_config import GripperConfig

PART_HEIGHT_MM = PROFILE_SECTION_MM
"""Profiles and brackets both stand 40 mm tall on the table."""


def part_boxes(part: Part) -> np.ndarray:
    """The part's solid as n×2×3 boxes (lo, hi) in world mm at its pose."""
    return np.array(
        [[[x0, y0, 0.0], [x1, y1, PART_HEIGHT_MM]] for x0, y0, x1, y1 in part.footprint_boxes()]
    )


@dataclass(frozen=True)
class Grasp:
    """A top-down grasp: TCP (centre between the fingertips) in world mm at the part's final pose,
    the world direction `yaw` (rad) in which the fingers open, and the opening they hold."""

    tcp: tuple[float, float, float]
    yaw: float
    opening: float

    def gripper_boxes(self, gripper: GripperConfig) -> np.ndarray:
        """Two fingers and the palm as 3×2×3 world boxes (the tool is aligned with the axes)."""
        along_x = abs(math.cos(self.yaw)) > 0.5
        t, w = gripper.finger_thickness, gripper.finger_width
        tip = self.tcp[2]
        root = tip + gripper.finger_length
        half_span = self.opening / 2 + t
        palm = (gripper.palm_width / 2, gripper.palm_depth / 2)
        # (across the opening, along the edge, z) extents, then mapped to world x/y.
        local = [
            ((self.opening / 2, half_span), (-w / 2, w / 2), (tip, root)),
            ((-half_span, -self.opening / 2), (-w / 2, w / 2), (tip, root)),
            ((-palm[0], palm[0]), (-palm[1], palm[1]), (root, root + gripper.palm_height)),
        ]
        boxes = []
        for across, along, z in local:
            xs, ys = (across, along) if along_x else (along, across)
            boxes.append(
                [
                    [self.tcp[0] + xs[0], self.tcp[1] + ys[0], z[0]],
                    [self.tcp[0] + xs[1], self.tcp[1] + ys[1], z[1]],
                ]
            )
        return np.array(boxes)


def grasp_candidates(part: Part, gripper: GripperConfig, fractions: Sequence[float]) -> list[Grasp]:
    """Top-down grasps of `part` in the world: a fixed set per part type, as the paper's
    simulator has (grasp planning is named there as a restriction for future work, Sec. IV-A).

    A profile is held with the fingers on its two long faces at each fraction of its length. A
    bracket is held across the wall of one leg at the middle of the leg's free stretch, the
    fingertips `bracket_grip_depth` below its top (one grasp per leg): the outer finger then
    stands where the profile that leg is fastened to goes, so that profile must come later.
    """
    turn = part.quarter_turns * math.pi / 2
    if part.type.is_profile:
        local = [
            ((0.0, (f - 0.5) * part.type.length, gripper.grasp_height), 0.0, PROFILE_SECTION_MM)
            for f in fractions
        ]
    else:
        mid = (BRACKET_THICKNESS_MM + BRACKET_LEG_MM) / 2
        tip = PART_HEIGHT_MM - gripper.bracket_grip_depth
        wall = BRACKET_THICKNESS_MM / 2
        local = [
            ((mid, wall, tip), math.pi / 2, BRACKET_THICKNESS_MM),
            ((wall, mid, tip), 0.0, BRACKET_THICKNESS_MM),
        ]
    grasps = []
    for (x, y, z), yaw, opening in local:
        world = part.pose[:2, :2] @ np.array([x, y]) + part.pose[:2, 3]
        grasps.append(Grasp((float(world[0]), float(world[1]), z), turn + yaw, opening))
    return grasps


def segment_sweeps(boxes: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Boxes covering `boxes` (…×2×3, at the final pose) carried from each start offset to its
    end offset (broadcast): per segment, the box spanning the start and end copies."""
    lo = np.minimum(boxes[..., 0, :] + starts, boxes[..., 0, :] + ends)
    hi = np.maximum(boxes[..., 1, :] + starts, boxes[..., 1, :] + ends)
    return np.stack([lo, hi], axis=-2)


def segment_samples(start: np.ndarray, end: np.ndarray, step: float) -> np.ndarray:
    """Offsets (K×3, mm) along one segment, at most `step` apart, both ends included."""
    n = max(1, math.ceil(np.linalg.norm(end - start) / step))
    return start + (end - start) * (np.arange(n + 1) / n)[:, None]


def tcp_samples(tcp: tuple[float, float, float], motion: Motion, step: float) -> np.ndarray:
    """TCP positions (K×3, mm) along `motion`, at most `step` apart, waypoints included."""
    points = [segment_samples(a, b, step) for a, b in motion.segments()]
    return np.asarray(tcp) + np.concatenate(points)
