"""The fixture's swing clamps: a post fixed to the plate per profile, its arm swung over the
profile once placed (docs/world.md, "The cell").

A swing clamp's post (its body) is bolted to the fixture plate before any part arrives, so it is
an obstacle for the gripper, the held part and the arms at every step, also before its profile
is placed and also for that profile itself. Its arm swings over the profile's top only once the
profile is placed and the gripper has left, so the arm is an obstacle for later parts only (it
shares the profile's bit in the blocker masks; a post is there in every state). The arm rides on
the post's rod, so the post reaches up to the arm's top.

The fixture designer puts each post on a free spot beside its profile (no other part's
footprint and no other post within its footprint), preferring spots that leave a finger's
thickness of room to every other part and post (a post in a narrower gap would shut the
gripper out of it on both sides), then the spot nearest the profile's middle, then the side
facing the frame's centre, then the lower position. Parts come in from outside the frame (a
stem slides along its hosts' grooves from their open ends, a host along its axis from beyond
its end), so a post outside would stand in those paths, e.g. in the way of the last rung of a
rectangle. A profile with no free spot on either side gets no clamp. The placement is a
function of the assembly's geometry alone, so it is the same for every order and every
simulator, and an imported assembly gets the same clamps.
"""

from __future__ import annotations

import numpy as np

from grace.domain.assembly import PROFILE_SECTION_MM, Assembly, Part
from grace.simulation.cell_config import ClampConfig
from grace.simulation.joints import Box, axis_of

HALF = PROFILE_SECTION_MM / 2


def clamp_boxes(
    assembly: Assembly, cfg: ClampConfig, clearance: float, tolerance: float
) -> list[np.ndarray]:
    """Per part, its clamp as k×2×3 boxes (lo, hi) in world mm: the post, then the arm (k = 0
    for brackets and for a profile without room); `clearance` is the room (mm) the designer
    prefers to leave around a post (the gripper's finger thickness)."""
    footprints = [[box for box in p.footprint_boxes()] for p in assembly.parts]
    centre = np.mean([p.xy for p in assembly.parts], axis=0)
    taken: list[Box] = []
    top = PROFILE_SECTION_MM + cfg.arm_thickness  # the post carries the arm on its top
    out = []
    for i, part in enumerate(assembly.parts):
        others = [box for j, boxes in enumerate(footprints) if j != i for box in boxes]
        spot = (
            _spot(part, cfg, others + taken, centre, tolerance, clearance)
            if part.type.is_profile
            else None
        )
        if spot is None:
            out.append(np.zeros((0, 2, 3)))
            continue
        body, arm = spot
        taken.append(body)
        out.append(
            np.array(
                [
                    [[body[0], body[1], 0.0], [body[2], body[3], top]],
                    [
                        [arm[0], arm[1], PROFILE_SECTION_MM],
                        [arm[2], arm[3], PROFILE_SECTION_MM + cfg.arm_thickness],
                    ],
                ]
            )
        )
    return out


def _spot(
    part: Part,
    cfg: ClampConfig,
    obstacles: list[Box],
    centre: np.ndarray,
    tolerance: float,
    clearance: float,
) -> tuple[Box, Box] | None:
    u = axis_of(part)
    n = np.array([-u[1], u[0]])
    half_span = part.type.length / 2 - cfg.width / 2
    steps = int(half_span // cfg.grid)
    positions = np.arange(-steps, steps + 1) * cfg.grid
    outward = float((np.asarray(part.xy) - centre) @ n)
    best: tuple[tuple[bool, float, float, float], tuple[Box, Box]] | None = None
    blocks = np.array(obstacles).reshape(-1, 4)
    room = blocks + np.array([-clearance, -clearance, clearance, clearance])
    for side in (1.0, -1.0):
        free = _free(part, u, n * side, positions, cfg, blocks, tolerance)
        clear = _free(part, u, n * side, positions, cfg, room, tolerance)
        for k in np.flatnonzero(free):
            at = float(positions[k])
            key = (bool(clear[k]), -abs(at), -side * outward, -at)
            if best is None or key > best[0]:
                best = (key, _boxes(part, u, n * side, float(at), cfg))
    return None if best is None else best[1]


def _boxes(
    part: Part, u: np.ndarray, n: np.ndarray, along: float, cfg: ClampConfig
) -> tuple[Box, Box]:
    c = np.asarray(part.xy) + u * along
    body = _box(c + n * (HALF + cfg.depth / 2), u * cfg.width / 2, n * cfg.depth / 2)
    arm = _box(c + n * (cfg.depth / 2), u * cfg.arm_width / 2, n * (HALF + cfg.depth / 2))
    return body, arm


def _box(centre: np.ndarray, a: np.ndarray, b: np.ndarray) -> Box:
    half = np.abs(a) + np.abs(b)
    lo, hi = centre - half, centre + half
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def _free(
    part: Part,
    u: np.ndarray,
    n: np.ndarray,
    positions: np.ndarray,
    cfg: ClampConfig,
    blocks: np.ndarray,
    tolerance: float,
) -> np.ndarray:
    """Per candidate position, whether the clamp body there overlaps no obstacle footprint."""
    centre = np.asarray(part.xy) + n * (HALF + cfg.depth / 2)
    half = np.abs(u) * cfg.width / 2 + np.abs(n) * cfg.depth / 2
    centres = centre[None] + positions[:, None] * u[None]
    lo, hi = centres - half, centres + half
    depth_x = np.minimum(hi[:, None, 0], blocks[None, :, 2]) - np.maximum(
        lo[:, None, 0], blocks[None, :, 0]
    )
    depth_y = np.minimum(hi[:, None, 1], blocks[None, :, 3]) - np.maximum(
        lo[:, None, 1], blocks[None, :, 1]
    )
    return ~((depth_x > tolerance) & (depth_y > tolerance)).any(axis=1)
