"""Relative geometry of every ordered pair of parts: an input beyond the paper's Assembly Graph.

Whether part n can be placed when a set S is placed is, in the robot cell, a question about
pairs: n needs a placed part it touches (fixation), and each of its grasp and motion options is
blocked by the placed parts that stand in the fingers', palm's or held part's way
(docs/world.md). The paper's graph gives the network only the unsigned distance between parallel
surface planes, one surface pair at a time, from which "does m stand where n's fingers go" has to
be pieced together over many pairs. Here each ordered pair (m, n) gets m's footprint read in n's
own frame, so the network can read that directly (docs/assembly-graph.md, "Pair geometry").

Only relative quantities enter (n's frame moves and turns with n), so, like the paper's graph,
these features do not change when the whole assembly is moved or turned on the table. Both
generated and raw assemblies carry every part's pose (`assembly.spec`), so both have them.
"""

from __future__ import annotations

import functools

import numpy as np

from grace.domain.assembly import Assembly, Part, PartType

PAIR_GEOMETRY_FEATURES = 16
"""Width of one pair's features: m's box in n's frame (4), the gaps between the two boxes along
n's axes (2), m's turn relative to n (4, one-hot) and both part types (3 + 3, one-hot)."""


PART_TYPE_INDEX = {t: t.index for t in PartType}
"""PartType.index of every type, looked up without building the list of types each time."""


def _codes() -> np.ndarray:
    """(4, T, T, 10): the one-hot features of a pair by (m's quarter turn relative to n, m's type,
    n's type)."""
    types = len(PartType)
    codes = np.zeros((4, types, types, 4 + 2 * types))
    for turn in range(4):
        for m in range(types):
            for n in range(types):
                codes[turn, m, n, [turn, 4 + m, 4 + types + n]] = 1.0
    return codes


_CODES = _codes()


@functools.cache
def _local_corners(part_type: PartType) -> np.ndarray:
    """(8, 2): the corners of the footprint boxes of a part of this type in its own frame
    (Part.footprint_boxes at the identity pose); a one-box type repeats its box, which leaves
    every min and max as it is."""
    boxes = Part("", part_type, np.eye(4)).footprint_boxes()
    corners = [((x0, y0), (x1, y1), (x0, y1), (x1, y0)) for x0, y0, x1, y1 in boxes]
    return np.asarray(corners * (2 // len(boxes)), dtype=np.float64).reshape(8, 2)


def pair_geometry(assembly: Assembly, scale: float) -> np.ndarray:
    """(N, N, PAIR_GEOMETRY_FEATURES) float array, `[m, n]` = part m seen from part n; lengths
    divided by `scale` mm; the diagonal is 0.

    All pairs at once, in a few array operations on (N, N) arrays (the encoding is on the path
    of a cold next-step query). Poses turn by quarter turns, so a box's turned corners are the
    corners of the turned box: m's bounding box seen from n is its two world corners moved into
    n's frame, then sorted per axis."""
    parts = assembly.parts
    n = len(parts)
    poses = np.stack([p.pose for p in parts])
    rot, shift = poses[:, :2, :2], poses[:, :2, 3]  # (N, 2, 2), (N, 2)
    local = np.stack([_local_corners(p.type) for p in parts])
    world = local @ rot.transpose(0, 2, 1) + shift[:, None]  # (N, 8, 2)
    corners = np.stack([world.min(axis=1), world.max(axis=1)])  # (2, N, 2): low, high
    # seen[c, k, m] = R_kᵀ (corner c of m − t_k): m's two box corners in k's frame.
    d = corners[:, None] - shift[None, :, None]  # (2, N_from, N, 2)
    seen = d[..., :1] * rot[None, :, None, 0] + d[..., 1:] * rot[None, :, None, 1]
    box = np.concatenate([seen.min(axis=0), seen.max(axis=0)], axis=-1)  # (N_from, N, 4)
    diagonal = np.arange(n)
    own = box[diagonal, diagonal][:, None]  # (N_from, 1, 4): each part in its own frame
    gaps = np.maximum(box[..., :2] - own[..., 2:], own[..., :2] - box[..., 2:])
    turns = np.array([p.quarter_turns for p in parts])
    types = np.array([PART_TYPE_INDEX[p.type] for p in parts])
    codes = _CODES[(turns[:, None] - turns[None, :]) % 4, types[:, None], types[None, :]]
    out = np.concatenate(
        [np.concatenate([box, gaps], axis=-1).transpose(1, 0, 2) / scale, codes], axis=-1
    )
    out[diagonal, diagonal] = 0.0
    return out
