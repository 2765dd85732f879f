"""Contacts and T-slot joints read off an assembly's geometry, and the motions they allow.

The joint physics of docs/world.md ("Rule: joints"). Every joint is a connector in a T-slot
groove running along a profile's long side. A connector head enters a groove either along the
groove, from the profile's end, or through the groove's mouth while the part carrying it is
pushed in horizontally; never vertically through the groove's lips. Hence:

- a stem (a profile whose end meets another's long side) placed after its host slides its last
  stretch along its own axis into the joint, or slides sideways along the host's groove,
  entering it from an open end (`side_slides`); it cannot be lowered onto a placed host;
- a host placed after stems or brackets fastened to its side slides along its own axis until
  every such connector has entered its groove from the leading end;
- a profile joined at both ends cannot slide along its axis into one host while the other is
  placed; sideways it enters both grooves at once.

A motion records, as `joint_blockers`, the placed parts whose connection it cannot make.
Everything works on table footprints (`Part.footprint_boxes`, docs/assembly-graph.md), in mm.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from itertools import combinations

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
    profile's centre along its axis, spanning `half_span` mm either side, in the groove of the
    long side `side` (+1 or −1 along the profile's normal (−u_y, u_x), u = `axis_of`)."""

    profile: int
    partner: int
    along: float
    half_span: float
    side: int


def connectors(parts: Sequence[Part], tolerance: float = 0.5) -> list[Connector]:
    """Every connector in a profile's side groove: stem ends and bracket legs."""
    out = [
        Connector(j.host, j.part, j.along, HALF, _side(parts[j.host], -np.asarray(j.direction)))
        for j in end_joints(parts, tolerance)
    ]
    for b, bracket in enumerate(parts):
        if bracket.type.is_profile:
            continue
        for p, profile in enumerate(parts):
            if not profile.type.is_profile:
                continue
            if parts_contact(bracket, profile, tolerance) < BRACKET_LEG_MM - tolerance:
                continue
            leg = next(box for box in bracket.footprint_boxes() if _along_axis(box, profile))
            lo, hi = _extent_along(leg, profile)
            middle = np.array([leg[0] + leg[2], leg[1] + leg[3]]) / 2 - np.asarray(profile.xy)
            out.append(Connector(p, b, (lo + hi) / 2, (hi - lo) / 2, _side(profile, middle)))
    return out


def _side(profile: Part, offset: np.ndarray) -> int:
    """Which long side of `profile` (±1 along its normal) the world vector `offset` points to."""
    u = axis_of(profile)
    return 1 if float(offset @ np.array([-u[1], u[0]])) > 0 else -1


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


def _bits(parts: Iterable[int]) -> int:
    return sum(1 << p for p in set(parts))


Way = tuple[str, np.ndarray | None, float, int]
"""A motion's shape: kind, slide direction (None: top-down), travel, joint blockers."""


def lowered(
    kind: str,
    direction: np.ndarray | None,
    travel: float,
    heights: Sequence[float],
    blockers: int = 0,
) -> Motion:
    """Carried in at the last of `heights` (ascending), lowered `travel` mm back along
    `direction` (top-down: straight onto its pose), then slid along it into the final pose.
    The lower heights are stops on the way down: the path is the same, and the segments it
    shares with a part carried in lower are the same (the cell sweeps them once)."""
    back = np.zeros(2) if direction is None else -np.asarray(direction, dtype=float) * travel
    column = [[back[0], back[1], h] for h in reversed(heights)]
    rest = [[0.0, 0.0, 0.0]] if direction is None else [[back[0], back[1], 0.0], [0.0, 0.0, 0.0]]
    towards = None if direction is None else (float(direction[0]), float(direction[1]))
    return Motion(kind, np.array(column + rest), towards, blockers)


def insertion_motions(
    assembly: Assembly,
    slide_length: float,
    slide_lead: float,
    carry_heights: Sequence[float],
    tolerance: float = 0.5,
) -> list[list[Motion]]:
    """Candidate motions per part with the connections each cannot make (module docstring),
    each once per height in `carry_heights` (ascending) the part may be carried in at.

    A bracket is lowered top-down (its connectors are pushed into the groove through the mouth).
    A profile may be lowered top-down, which connects nothing, or slide along its axis either
    way: by `slide_length`, and by as far as each connector on its side needs to be taken in
    from the leading end plus `slide_lead`. A stem may also slide sideways along its hosts'
    grooves (`side_slides`).
    """
    parts = assembly.parts
    joints = end_joints(parts, tolerance)
    grooves = connectors(parts, tolerance)
    out: list[list[Motion]] = []
    for i, part in enumerate(parts):
        if not part.type.is_profile:
            out.append(_per_height([("top_down", None, 0.0, 0)], carry_heights))
            continue
        mine = [c for c in grooves if c.profile == i]
        hosts = {j.direction: j.host for j in joints if j.part == i}
        partners = _bits(c.partner for c in mine) | _bits(hosts.values())
        ways: list[Way] = [("top_down", None, 0.0, partners)]
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
                ways.append(("slide", d, travel, blockers))
        ways += side_slides(i, parts, joints, grooves, slide_lead)
        out.append(_per_height(ways, carry_heights))
    return out


def _per_height(ways: list[Way], heights: Sequence[float]) -> list[Motion]:
    return [
        lowered(*way[:3], heights[: k + 1], way[3]) for k in range(len(heights)) for way in ways
    ]


def side_slides(
    stem: int,
    parts: Sequence[Part],
    joints: Sequence[EndJoint],
    grooves: Sequence[Connector],
    slide_lead: float,
) -> list[Way]:
    """A stem's slides along its hosts' grooves, entering from an open end (docs/world.md).

    The hosts of a stem (one per joined end) are parallel, so one slide can take the stem's end
    connectors into both grooves. For each end it may enter from and each set H of hosts it
    enters: the stem is lowered `slide_lead` beyond the farthest end of H and slides to its
    pose. It cannot be made once a host outside H is placed (the connector would start inside
    that groove), nor once a part closes the entered end of a host of H (a profile whose side
    covers it: the groove's end cap), a connector lies in that groove between the end and the
    stem, or a connector sits in the stem's own grooves (it would have to enter across them).
    """
    mine = _bits(c.partner for c in grooves if c.profile == stem)
    ends = [j for j in joints if j.part == stem]
    if not ends:
        return []
    w = np.abs(axis_of(parts[ends[0].host]))  # the world axis all its hosts' grooves run along
    at = float(np.asarray(parts[stem].xy) @ w)
    out = []
    for s in (1, -1):
        entry = {}  # host → (travel to clear its end + lead, what closes that way in)
        for j in ends:
            host = parts[j.host]
            centre = float(np.asarray(host.xy) @ w)
            end = centre + s * host.type.length / 2
            travel = s * (end - at) + HALF + slide_lead
            flip = float(axis_of(host) @ w)  # +1 if the host's axis points along w
            side = _side(host, np.asarray(parts[stem].xy) - np.asarray(host.xy))
            lo, hi = sorted((at, end))
            in_path = [
                c.partner
                for c in grooves
                if c.profile == j.host
                and c.partner != stem
                and c.side == side
                and min(hi, centre + flip * c.along + c.half_span)
                - max(lo, centre + flip * c.along - c.half_span)
                > 0
            ]
            cap = [e.host for e in joints if e.part == j.host and e.direction == _key(w * s)]
            entry[j.host] = (travel, _bits(in_path) | _bits(cap))
        for k in range(1, len(entry) + 1):
            for taken in combinations(sorted(entry), k):
                travel = max(entry[h][0] for h in taken)
                blockers = mine | _bits(h for h in entry if h not in taken)
                for h in taken:
                    blockers |= entry[h][1]
                out.append(("side_slide", -w * s, travel, blockers))
    return out


def _key(v: np.ndarray) -> tuple[int, int]:
    return (round(float(v[0])), round(float(v[1])))
