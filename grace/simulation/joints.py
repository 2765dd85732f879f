"""Contacts and joints read off an assembly's geometry, and the insertion motions they imply.

Issue 2, "the motion follows the joint": a part is lowered top-down onto the table, but a profile
whose end joins the long side of another (a T-slot connector, as in T-joints and L-corners) slides
its last stretch horizontally along its own axis into that joint. Everything works on the parts'
table footprints (`Part.footprint_boxes`, SPEC §2 conventions), in millimetres.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import PROFILE_SECTION_MM, Assembly, Part
from grace.domain.motion import Motion

Box = tuple[float, float, float, float]
"""An axis-aligned footprint box (xmin, ymin, xmax, ymax) in world mm."""


def boxes_overlap(a: Box, b: Box, tolerance: float) -> bool:
    """True if the interiors of `a` and `b` intersect deeper than `tolerance` on both axes."""
    dx = min(a[2], b[2]) - max(a[0], b[0])
    dy = min(a[3], b[3]) - max(a[1], b[1])
    return dx > tolerance and dy > tolerance


def contact_length(a: Box, b: Box, tolerance: float) -> float:
    """Length of the boundary `a` and `b` share (faces within `tolerance`), 0 if none."""
    if boxes_overlap(a, b, tolerance):
        return 0.0
    dx = min(a[2], b[2]) - max(a[0], b[0])
    dy = min(a[3], b[3]) - max(a[1], b[1])
    if abs(dx) <= tolerance and dy > tolerance:
        return dy
    if abs(dy) <= tolerance and dx > tolerance:
        return dx
    return 0.0


def parts_overlap(a: Part, b: Part, tolerance: float) -> bool:
    return any(
        boxes_overlap(p, q, tolerance) for p in a.footprint_boxes() for q in b.footprint_boxes()
    )


def parts_contact(a: Part, b: Part, tolerance: float) -> float:
    """Total face length two parts share; 0 for parts that do not touch."""
    return sum(
        contact_length(p, q, tolerance) for p in a.footprint_boxes() for q in b.footprint_boxes()
    )


def touching(assembly: Assembly, tolerance: float = 0.5) -> np.ndarray:
    """n×n bool contact relation: parts sharing a face or an end within `tolerance` mm.

    Fixation (a later profile must touch a placed part) and the nonlocal-block statistic use it.
    """
    n = assembly.n_parts
    rel = np.zeros((n, n), dtype=bool)
    for i in range(n):
        for j in range(i + 1, n):
            rel[i, j] = rel[j, i] = (
                parts_contact(assembly.parts[i], assembly.parts[j], tolerance) > 0
            )
    return rel


@dataclass(frozen=True)
class EndJoint:
    """Profile `part`'s end surface `end` (1 or 3) sits against a long side of profile `host`.

    `direction` is the end's outward unit normal: the way the part slides into the joint.
    """

    part: int
    end: int
    host: int
    direction: tuple[int, int]


def end_joints(parts: Sequence[Part], tolerance: float = 0.5) -> list[EndJoint]:
    """All T-slot joints among `parts`: a profile end fully supported by another's long side."""
    profiles = [(i, p) for i, p in enumerate(parts) if p.type.is_profile]
    surfaces = [s for i, p in profiles for s in p.surfaces(i)]
    ends = [s for s in surfaces if s.index in (1, 3)]
    sides = [s for s in surfaces if s.index in (2, 4)]
    half = PROFILE_SECTION_MM / 2
    joints = []
    for e in ends:
        n = np.asarray(e.normal, dtype=float)
        t = np.array([-n[1], n[0]])
        for s in sides:
            if s.part == e.part or tuple(-n) != tuple(float(v) for v in s.normal):
                continue
            offset = np.asarray(s.center) - np.asarray(e.center)
            if abs(offset @ n) > tolerance:
                continue
            side_half = parts[s.part].type.length / 2
            if abs(offset @ t) + half <= side_half + tolerance:
                joints.append(EndJoint(e.part, e.index, s.part, (int(n[0]), int(n[1]))))
    return joints


def insertion_motions(
    assembly: Assembly, slide_length: float, approach_height: float, tolerance: float = 0.5
) -> list[list[Motion]]:
    """Candidate insertion motions per part: one slide per joined end, else one top-down drop."""
    slides: dict[int, list[Motion]] = {}
    for joint in end_joints(assembly.parts, tolerance):
        d = np.asarray(joint.direction, dtype=float)
        back = -d * slide_length
        waypoints = np.array(
            [[back[0], back[1], approach_height], [back[0], back[1], 0.0], [0.0, 0.0, 0.0]]
        )
        motion = Motion("slide", waypoints, (float(d[0]), float(d[1])))
        slides.setdefault(joint.part, []).append(motion)
    drop = Motion("top_down", np.array([[0.0, 0.0, approach_height], [0.0, 0.0, 0.0]]))
    return [slides.get(i, [drop]) for i in range(assembly.n_parts)]
