"""Large frames built in sections along the table (docs/world.md, "Large frames").

A fixture or machine frame of 30 to 50 profiles is not one tangle of T-joints: it is bays of a
few profiles each, joined by cross members. `sectioned_frame` builds one that way: sections
grown by the ordinary motifs (`StructureGenerator`), each accepted only if `section_ok` says so
(the simulator's ground truth: a feasible bay), laid one after the other along world y, each
joined to the one before by a link, a profile spanning a profile of each at a profile's length
(both ends in T-slots, a rung between the bays). Apart from the link, two sections keep
`section_gap_mm` of room between them (a clamp's base and a finger's room), so what blocks a
step stays mostly within its bay, as in the frames of the default world.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from grace.domain.assembly import PROFILE_SECTION_MM, Part, PartType, planar_pose
from grace.simulation.joints import end_joints, parts_contact, parts_overlap

HALF = PROFILE_SECTION_MM / 2
_LINKS = (PartType.PROFILE_200, PartType.PROFILE_300)


def section_sizes(n_parts: int, most: int) -> list[int]:
    """Parts per section for a frame of `n_parts` (a link between consecutive sections): as
    few sections of at most `most` parts as fit, sizes as even as possible."""
    count = -(-(n_parts + 1) // (most + 1))
    rest = n_parts - (count - 1)
    return [rest // count + (i < rest % count) for i in range(count)]


def _boxes(parts: Sequence[Part]) -> np.ndarray:
    return np.array([b for p in parts for b in p.footprint_boxes()])


def _gap(a: np.ndarray, b: np.ndarray) -> float:
    """The smallest clearance (mm, Chebyshev: along x or y) between two sets of boxes."""
    dx = np.maximum(b[None, :, 0] - a[:, None, 2], a[:, None, 0] - b[None, :, 2])
    dy = np.maximum(b[None, :, 1] - a[:, None, 3], a[:, None, 1] - b[None, :, 3])
    return float(np.maximum(dx, dy).min())


def _shifted(parts: Sequence[Part], dx: float, dy: float) -> list[Part]:
    out = []
    for p in parts:
        pose = p.pose.copy()
        pose[:2, 3] += (dx, dy)
        out.append(Part(p.name, p.type, pose))
    return out


def edge_profiles(parts: Sequence[Part], far: bool, tolerance: float) -> list[Part]:
    """The x-axis profiles on the frame's far (+y) or near (−y) edge: where a link may join."""
    boxes = _boxes(parts)
    edge = boxes[:, 3].max() if far else boxes[:, 1].min()
    side = HALF if far else -HALF
    return [
        p
        for p in parts
        if p.type.is_profile and p.quarter_turns % 2 and abs(p.xy[1] + side - edge) <= tolerance
    ]


def link(
    frame: list[Part],
    section: list[Part],
    rng: np.random.Generator,
    gap: float,
    grid: float,
    tolerance: float,
    width: float = np.inf,
) -> tuple[Part, Part, list[Part]] | None:
    """(host, link, section moved): `section` moved beyond `frame` along +y, and the link
    joining a profile of each, the host on the frame's far edge; None if no pair of facing
    profiles gives a link whose ends sit fully on both, with `gap` mm between the rest of the
    two and the whole at most `width` mm wide (x)."""
    hosts = edge_profiles(frame, True, tolerance)
    guests = edge_profiles(section, False, tolerance)
    candidates = [(a, b, k) for a in hosts for b in guests for k in _LINKS]
    old = _boxes(frame)
    for i in rng.permutation(len(candidates)):
        host, guest, kind = candidates[i]
        span = int((host.type.length / 2 - HALF) // grid)  # where the link stands on the host
        at = host.xy[0] + float(rng.integers(-span, span + 1)) * grid
        reach = int((guest.type.length / 2 - HALF) // grid)
        dx = at - guest.xy[0] + float(rng.integers(-reach, reach + 1)) * grid
        dy = host.xy[1] + HALF + kind.length + HALF - guest.xy[1]
        moved = _shifted(section, dx, dy)
        both = np.concatenate([old, _boxes(moved)])
        if both[:, 2].max() - both[:, 0].min() > width or _gap(old, _boxes(moved)) < gap:
            continue
        bar = Part("new", kind, planar_pose(at, host.xy[1] + HALF + kind.length / 2, 0))
        joined = [p for p in (*frame, *moved) if parts_contact(bar, p, tolerance) > 0]
        if (
            len(joined) == 2
            and not any(parts_overlap(bar, p, tolerance) for p in (*frame, *moved))
            and len(end_joints([*joined, bar], tolerance)) == 2
        ):
            return host, bar, moved
    return None


def sectioned_frame(
    sizes: Sequence[int],
    grow: Callable[[int], list[Part] | None],
    section_ok: Callable[[list[Part], int], bool],
    rng: np.random.Generator,
    gap: float,
    grid: float,
    tolerance: float,
    tries: int,
    width: float = np.inf,
    frame_ok: Callable[[list[Part]], bool] | None = None,
    frame_tries: int = 3,
) -> list[Part] | None:
    """A frame of sections of `sizes` parts (see the module docstring); `grow(n)` grows one
    section (None if it failed). The frame is built section by section, each from its first
    part on (the first one's first grown profile, a later one's link end), so
    `section_ok(piece, head)` is asked about the first section alone (`head` its size) and
    about each later one as the piece [previous link, previous section, link, section]
    (`head` the size of what comes before the new link): whether an order of the piece starts
    with its part 0 and passes the state where its first `head` parts are placed (asked
    last: the simulator's ground truth costs most). Each section gets `tries` attempts; the
    frame stays at most `width` mm wide (x); `frame_ok`, if given, must accept the frame as
    it grows, after each section (asked after `section_ok`; after `frame_tries` refusals
    the frame so far is given up: what it holds may leave no section an order). None if a
    section never makes it."""
    frame: list[Part] = []
    last: list[Part] = []  # the previous section, from its first part (its link, if any) on
    for i, size in enumerate(sizes):
        refused = 0
        for _ in range(tries):
            if refused == frame_tries:
                return None
            section = grow(size)
            if section is None or (
                i < len(sizes) - 1 and not edge_profiles(section, True, tolerance)
            ):
                continue  # a section before the last needs a profile to link the next one to
            if not frame:
                if section_ok(section, len(section)):
                    if frame_ok is None or frame_ok(section):
                        frame = last = section
                        break
                    refused += 1
                continue
            joined = link(last, section, rng, gap, grid, tolerance, width)
            if joined is None:
                continue
            _, bar, moved = joined
            guest = next(p for p in moved if parts_contact(bar, p, tolerance) > 0)
            moved = [guest, *(p for p in moved if p is not guest)]
            grown = [*frame, bar, *moved]
            if section_ok([*last, bar, *moved], len(last)):
                if frame_ok is None or frame_ok(grown):
                    frame, last = grown, [bar, *moved]
                    break
                refused += 1
        else:
            return None
    return frame
