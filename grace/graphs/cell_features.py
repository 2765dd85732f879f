"""What the cell decides beside the assembly, as part-node features: an oracle input beyond the
paper's Assembly Graph (docs/information-ceiling.md, `model.graph.cell`).

The paper's graph (Sec. IV-B) holds only the assembly: parts, surfaces and their relative
geometry, the same wherever the frame stands on the table. Whether a step is feasible also
depends on the cell (docs/world.md): the clamp the fixture designer puts beside each profile
(an obstacle from the start, taller once closed) and where the part stands relative to the two
arms' bases (reach, and the arm's links over the clamps). With this option each part node also
gets, in this order:
- its clamp: whether it has one, the top of its tallest solid, and the base's centre seen from
  the part's centre in the part's own frame (along its axis, across it);
- its pose on the table: the centre (x, y) and the cosine and sine of its turn;
- its distance (in the table plane) from the foot of each arm's base (0 for a missing arm).
Lengths are divided by the encoding's `distance_scale`. The clamps are the simulator's own
design (grace/simulation/clamps.py), a function of the assembly and the cell alone.
"""

from __future__ import annotations

import numpy as np

from grace.domain.assembly import Assembly
from grace.errors import UserError
from grace.simulation.cell_config import CellConfig
from grace.simulation.clamps import clamp_boxes
from grace.simulation.joints import axis_of

ARMS = 2
"""Arms whose distance each part carries (the default cell's two; a one-arm cell pads with 0)."""

CELL_FEATURES = 4 + 4 + ARMS
"""Width of the features one part node gains: clamp (4), pose (4), arm distances (ARMS)."""


def cell_features(assembly: Assembly, cell: CellConfig, scale: float) -> np.ndarray:
    """(N, CELL_FEATURES) float array of `assembly`'s parts in `cell`; lengths / `scale` mm."""
    if len(cell.bases) > ARMS:
        raise UserError(
            f"model.graph.cell: {len(cell.bases)} arms, the cell features hold {ARMS}; fix: a "
            "cell of at most two arms, or model.graph.cell=null"
        )
    clamps = clamp_boxes(assembly, cell.clamp, cell.gripper.finger_thickness, cell.touch_tolerance)
    bases = np.array([b[:2] for b in cell.bases], dtype=np.float64).reshape(-1, 2)
    out = np.zeros((assembly.n_parts, CELL_FEATURES))
    for i, (part, clamp) in enumerate(zip(assembly.parts, clamps, strict=True)):
        centre = np.asarray(part.xy)
        if len(clamp.boxes):
            u = axis_of(part)
            seen = clamp.boxes[0, :, :2].mean(axis=0) - centre
            top = clamp.boxes[:, 1, 2].max()
            out[i, :4] = [1.0, top / scale, seen @ u / scale, seen @ [-u[1], u[0]] / scale]
        turn = part.pose[:2, 0]
        out[i, 4:8] = [*(centre / scale), *turn]
        out[i, 8 : 8 + len(bases)] = np.linalg.norm(bases - centre, axis=1) / scale
    return out
