"""Contacts and T-slot joints read off an assembly's geometry, and the motions they allow.

The joint physics of docs/world.md ("Rule: joints"). Every joint is a connector in a T-slot
groove running along a profile's long side. A connector head enters a groove either along the
groove, from the profile's end, or through the groove's mouth while the part carrying it is
pushed in horizontally; never vertically through the groove's lips. Hence:

- a stem (a profile whose end meets another's long side) placed after its host slides its last
  stretch along its own axis into the joint; it cannot be lowered onto a placed host;
- a host placed after stems or brackets fastened to its side slides along its own axis until
  every such connector has entered its groove from the leading end;
- a profile joined at both ends cannot slide into one host while the other is placed.

A motion records, as `joint_blockers`, the placed parts whose connection it cannot make.
Everything works on table footprints (`Part.footprint_boxes`, docs/assembly-graph.md), in mm.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import (
    BRACKET_LEG_MM,
    BRACKET_THICKNESS_MM,
    PROFILE_SECTION_MM,
    Assembly,
    Part,
)
from grace.domain.motion import Motion

Box = tuple[float, float, float, float]
"""An axis-aligned footprint box (xmin, ymin, xmax, ymax) in world mm."""

HALF = PROFILE_SECTION_MM / 2


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
    """n×n bool contact relation: parts sharing a face within `tolerance` mm."""
    n = assembly.n_parts
    rel = np.zeros((n, n), dtype=bool)
    for i in range(n):
        for j in range(i + 1, n):
            rel[i, j] = rel[j, i] = (
                parts_contact(assembly.parts[i], assembly.parts[j], tolerance) > 0
            )
    return rel


def axis_of(part: Part) -> np.ndarray:
    """World unit vector along a profile's length."""
    return np.round(part.pose[:2, 1]).astype(float)


@dataclass(frozen=True)
class EndJoint:
    """Profile `part`'s end surface `end` (1 or 3) sits fully against a long side of `host`.

    `direction` is the end's outward unit normal: the way the part slides into the joint.
    `along` is the joint's position along the host's axis, from the host's centre (mm).
    """

    part: int
    end: int
    host: int
    direction: tuple[int, int]
    along: float


def end_joints(parts: Sequence[Part], tolerance: float = 0.5) -> list[EndJoint]:
    """All T-slot joints among `parts`: a profile end fully supported by another's long side."""
    profiles = [(i, p) for i, p in enumerate(parts) if p.type.is_profile]
    surfaces = [s for i, p in profiles for s in p.surfaces(i)]
    ends = [s for s in surfaces if s.index in (1, 3)]
    sides = [s for s in surfaces if s.index in (2, 4)]
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
            host = parts[s.part]
            if abs(offset @ t) + HALF <= host.type.length / 2 + tolerance:
                along = float((np.asarray(e.center) - np.asarray(host.xy)) @ axis_of(host))
                joints.append(EndJoint(e.part, e.index, s.part, (int(n[0]), int(n[1])), along))
    return joints


@dataclass(frozen=True)
class Connector:
    """A connector of part `partner` in the groove of profile `profile`, at `along` mm from the
    profile's centre along its axis, spanning `half_span` mm either side."""

    profile: int
    partner: int
    along: float
    half_span: float


def connectors(parts: Sequence[Part], tolerance: float = 0.5) -> list[Connector]:
    """Every connector in a profile's side groove: stem ends and bracket legs."""
    out = [Connector(j.host, j.part, j.along, HALF) for j in end_joints(parts, tolerance)]
    for b, bracket in enumerate(parts):
        if bracket.type.is_profile:
            continue
        for p, profile in enumerate(parts):
            if not profile.type.is_profile:
                continue
            if parts_contact(bracket, profile, tolerance) < BRACKET_LEG_MM - tolerance:
                continue
            leg = [box for box in bracket.footprint_boxes() if _along_axis(box, profile)]
            lo, hi = _extent_along(leg[0], profile)
            out.append(Connector(p, b, (lo + hi) / 2, (hi - lo) / 2))
    return out


def _along_axis(box: Box, profile: Part) -> bool:
    """True if the bracket leg `box` runs along `profile`'s axis (the leg fastened to it)."""
    extent = np.array([box[2] - box[0], box[3] - box[1]])
    return bool(extent @ np.abs(axis_of(profile)) > BRACKET_THICKNESS_MM + 1.0)


def _extent_along(box: Box, profile: Part) -> tuple[float, float]:
    u = axis_of(profile)
    centre = np.asarray(profile.xy)
    corners = np.array([[box[0], box[1]], [box[2], box[3]]]) - centre
    values = corners @ u
    return float(values.min()), float(values.max())


def insertion_motions(
    assembly: Assembly,
    slide_length: float,
    slide_lead: float,
    approach_height: float,
    tolerance: float = 0.5,
) -> list[list[Motion]]:
    """Candidate motions per part with the connections each cannot make (module docstring).

    A bracket is lowered top-down (its connectors are pushed into the groove through the mouth).
    A profile may be lowered top-down, which connects nothing, or slide along its axis either
    way: by `slide_length`, and by as far as each connector on its side needs to be taken in
    from the leading end plus `slide_lead`.
    """
    parts = assembly.parts
    joints = end_joints(parts, tolerance)
    grooves = connectors(parts, tolerance)
    drop = np.array([[0.0, 0.0, approach_height], [0.0, 0.0, 0.0]])
    out: list[list[Motion]] = []
    for i, part in enumerate(parts):
        if not part.type.is_profile:
            out.append([Motion("top_down", drop)])
            continue
        mine = [c for c in grooves if c.profile == i]
        hosts = {j.direction: j.host for j in joints if j.part == i}
        partners = sum(1 << c.partner for c in mine) | sum(1 << h for h in hosts.values())
        motions = [Motion("top_down", drop, None, partners)]
        u = axis_of(part)
        for sign in (1.0, -1.0):
            d = u * sign
            key = (int(d[0]), int(d[1]))
            behind = hosts.get((-key[0], -key[1]))
            # Distance from the leading end to each connector's far edge: it must pass that far.
            need = {c.partner: part.type.length / 2 - sign * c.along + c.half_span for c in mine}
            travels = sorted({slide_length, *(v + slide_lead for v in need.values())})
            for travel in travels:
                missed = sum(1 << q for q, v in need.items() if v + slide_lead > travel + 1e-6)
                blockers = missed | (1 << behind if behind is not None else 0)
                back = -d * travel
                waypoints = np.array(
                    [[back[0], back[1], approach_height], [back[0], back[1], 0.0], [0, 0, 0.0]]
                )
                motions.append(Motion("slide", waypoints, (float(d[0]), float(d[1])), blockers))
        out.append(motions)
    return out
