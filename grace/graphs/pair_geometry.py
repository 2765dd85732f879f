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

import numpy as np

from grace.domain.assembly import Assembly, Part, PartType

PAIR_GEOMETRY_FEATURES = 16
"""Width of one pair's features: m's box in n's frame (4), the gaps between the two boxes along
n's axes (2), m's turn relative to n (4, one-hot) and both part types (3 + 3, one-hot)."""


def _local_box(part: Part, frame: np.ndarray) -> np.ndarray:
    """(xmin, ymin, xmax, ymax) of `part`'s footprint in the frame whose world pose is `frame`."""
    corners = []
    for x0, y0, x1, y1 in part.footprint_boxes():
        corners += [(x0, y0), (x1, y1), (x0, y1), (x1, y0)]
    world = np.asarray(corners) - frame[:2, 3]
    local = world @ frame[:2, :2]  # R^T (p − t), row-wise
    return np.concatenate([local.min(axis=0), local.max(axis=0)])


def pair_geometry(assembly: Assembly, scale: float) -> np.ndarray:
    """(N, N, PAIR_GEOMETRY_FEATURES) float array, `[m, n]` = part m seen from part n; lengths
    divided by `scale` mm; the diagonal is 0."""
    parts = assembly.parts
    n = len(parts)
    types = list(PartType)
    out = np.zeros((n, n, PAIR_GEOMETRY_FEATURES))
    own = [_local_box(p, p.pose) for p in parts]
    for j, seen_from in enumerate(parts):
        for i, part in enumerate(parts):
            if i == j:
                continue
            box = _local_box(part, seen_from.pose)
            mine = own[j]
            gaps = np.maximum(box[:2] - mine[2:], mine[:2] - box[2:])
            turn = (part.quarter_turns - seen_from.quarter_turns) % 4
            out[i, j, :4] = box / scale
            out[i, j, 4:6] = gaps / scale
            out[i, j, 6 + turn] = 1.0
            out[i, j, 10 + types.index(part.type)] = 1.0
            out[i, j, 13 + types.index(seen_from.type)] = 1.0
    return out
