"""The fixture's clamps: one per profile, of the first type with room (docs/world.md, "The cell").

A clamp is a few solids in the frame of its spot beside the profile, each standing in the cell
at a time of its own (`cell_config.CLAMP_STATES`): its base is bolted to the plate before any
part arrives, so it is an obstacle at every step, also before its profile is placed and also for
that profile itself; what the clamp holds out while open stands until its profile is placed,
also while the gripper places that profile; what closing brings over the profile (an arm, a
handle pushed upright) stands once the profile is placed and the gripper has left.

The fixture designer puts each clamp on a free spot beside its profile (no other part's
footprint and no other clamp's footprint under any of its solids), preferring spots that leave
a finger's thickness of room to every other part and clamp (a clamp in a narrower gap would
shut the gripper out of it on both sides), then the spot nearest the profile's middle, then the
side facing the frame's centre, then the lower position. Parts come in from outside the frame (a
stem slides along its hosts' grooves from their open ends, a host along its axis from beyond
its end), so a clamp outside would stand in those paths, e.g. in the way of the last rung of a
rectangle. Of the clamp types (in the config's order) a profile gets the first that has such a
spot with room; the last type may also take a spot without room; a profile with no free spot
gets no clamp. The design is a function of the assembly's geometry alone, so it is the same for
every order and every simulator, and an imported assembly gets the same clamps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import PROFILE_SECTION_MM, Assembly, Part
from grace.simulation.cell_config import CLAMP_STATES, ClampConfig, ClampTypeConfig
from grace.simulation.joints import Box, axis_of

HALF = PROFILE_SECTION_MM / 2


@dataclass(frozen=True)
class Clamp:
    """The clamp of one profile: its type's name, its solids as k×2×3 world boxes (lo, hi) in
    mm, the base first, and per solid its index in `CLAMP_STATES`."""

    kind: str
    boxes: np.ndarray
    when: np.ndarray
    footprint: Box
    """What it takes of the plate beside its profile (x0, y0, x1, y1 mm)."""


NO_CLAMP = Clamp("none", np.zeros((0, 2, 3)), np.zeros(0, dtype=int), (0.0, 0.0, 0.0, 0.0))


def clamp_boxes(
    assembly: Assembly, cfg: ClampConfig, clearance: float, tolerance: float
) -> list[Clamp]:
    """Per part, its clamp (`NO_CLAMP` for brackets and for a profile without room);
    `clearance` is the room (mm) the designer wants around a clamp (the finger thickness)."""
    footprints = [[box for box in p.footprint_boxes()] for p in assembly.parts]
    centre = np.mean([p.xy for p in assembly.parts], axis=0)
    taken: list[Box] = []
    out = []
    for i, part in enumerate(assembly.parts):
        if not part.type.is_profile:
            out.append(NO_CLAMP)
            continue
        others = [box for j, boxes in enumerate(footprints) if j != i for box in boxes]
        blocks = np.array(others + taken).reshape(-1, 4)
        clamp = None
        for k, kind in enumerate(cfg.types):
            last = k == len(cfg.types) - 1
            spot = _spot(part, kind, cfg.grid, blocks, centre, tolerance, clearance, last)
            if spot is not None:
                clamp = _place(part, kind, *spot)
                break
        if clamp is None:
            out.append(NO_CLAMP)
            continue
        taken.append(clamp.footprint)
        out.append(clamp)
    return out


def _beside(kind: ClampTypeConfig) -> tuple[float, float, float]:
    """The type's footprint beside the profile: (along from, along to, out to)."""
    standing = [b for b in kind.boxes if b.out[1] > 0]
    return (
        min(b.along[0] for b in standing),
        max(b.along[1] for b in standing),
        max(b.out[1] for b in standing),
    )


def _spot(
    part: Part,
    kind: ClampTypeConfig,
    grid: float,
    blocks: np.ndarray,
    centre: np.ndarray,
    tolerance: float,
    clearance: float,
    anywhere: bool,
) -> tuple[float, float] | None:
    """(position along the profile, side ±1) of the best spot, None if there is none (only spots
    with room unless `anywhere`)."""
    u = axis_of(part)
    n = np.array([-u[1], u[0]])
    lo, hi, depth = _beside(kind)
    first = -part.type.length / 2 - lo
    last = part.type.length / 2 - hi
    positions = np.arange(np.ceil(first / grid), np.floor(last / grid) + 1) * grid
    outward = float((np.asarray(part.xy) - centre) @ n)
    room = blocks + np.array([-clearance, -clearance, clearance, clearance])
    best: tuple[tuple[bool, float, float, float], tuple[float, float]] | None = None
    for side in (1.0, -1.0):
        footprint = (part, u, n * side, (lo, hi), depth)
        clear = _free(*footprint, positions, room, tolerance)
        free = _free(*footprint, positions, blocks, tolerance) if anywhere else clear
        for k in np.flatnonzero(free):
            at = float(positions[k])
            key = (bool(clear[k]), -abs(at), -side * outward, -at)
            if best is None or key > best[0]:
                best = (key, (at, side))
    return None if best is None else best[1]


def _place(part: Part, kind: ClampTypeConfig, at: float, side: float) -> Clamp:
    """The type's solids at position `at` along `part`, on `side` (±1 along its normal)."""
    u = axis_of(part)
    n = np.array([-u[1], u[0]]) * side
    c = np.asarray(part.xy) + u * at + n * HALF  # on the side face, at the clamp's centre line
    boxes = []
    for b in kind.boxes:
        corners = np.array([c + u * a + n * o for a in b.along for o in b.out])
        boxes.append([[*corners.min(axis=0), b.z[0]], [*corners.max(axis=0), b.z[1]]])
    when = np.array([CLAMP_STATES.index(b.when) for b in kind.boxes])
    lo, hi, depth = _beside(kind)
    corners = np.array([c + u * a + n * o for a in (lo, hi) for o in (0.0, depth)])
    x0, y0 = corners.min(axis=0)
    x1, y1 = corners.max(axis=0)
    footprint = (float(x0), float(y0), float(x1), float(y1))
    return Clamp(kind.name, np.array(boxes, dtype=float), when, footprint)


def _free(
    part: Part,
    u: np.ndarray,
    n: np.ndarray,
    along: tuple[float, float],
    depth: float,
    positions: np.ndarray,
    blocks: np.ndarray,
    tolerance: float,
) -> np.ndarray:
    """Per candidate position, whether the footprint beside the profile (`along` × [0, depth]
    out along `n`) overlaps no obstacle footprint."""
    base = np.asarray(part.xy) + n * HALF
    corners = np.array([base + u * a + n * o for a in along for o in (0.0, depth)])
    lo0, hi0 = corners.min(axis=0), corners.max(axis=0)
    shift = positions[:, None] * u[None]
    lo, hi = lo0[None] + shift, hi0[None] + shift
    depth_x = np.minimum(hi[:, None, 0], blocks[None, :, 2]) - np.maximum(
        lo[:, None, 0], blocks[None, :, 0]
    )
    depth_y = np.minimum(hi[:, None, 1], blocks[None, :, 3]) - np.maximum(
        lo[:, None, 1], blocks[None, :, 1]
    )
    return ~((depth_x > tolerance) & (depth_y > tolerance)).any(axis=1)
