"""Top view of assemblies: part footprints, clamps, part numbers, surface numbers, feasibility.

Part numbers are the 0-based indices the orders use; surface numbers are the 1-based `k` of
`<part>_surface_<k>` (docs/assembly-graph.md), drawn just outside the face they name. Clamps
(docs/world.md) are the hatched boxes the simulator records in `info["clamps"]`. Rendered
without pyplot (a bare Figure, Agg canvas) into PNG bytes, so callers decide where (and how
atomically) to write.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from grace.domain.assembly import BRACKET_LEG_MM
from grace.domain.sample import LabelledAssembly

_COLOURS = {
    "item_profile_200": "#9fb7d9",
    "item_profile_300": "#6f93c6",
    "item_angle_bracket": "#e0a458",
}
_SURFACE_LABEL_OFFSET_MM = 9.0


def title(sample: LabelledAssembly) -> str:
    """`A5-000012: feasible, 12 orders` or `A5-000013: infeasible (collision)`."""
    name, size = sample.assembly.name, f"A{sample.size}"
    head = name if name.startswith(size) else f"{size} {name}".strip()
    if sample.truth.feasible:
        n = sample.truth.n_orders()
        return f"{head}: feasible, {n} order{'s' if n != 1 else ''}"
    why = ", ".join(sample.info.get("mechanisms") or []) or sample.info.get("cause")
    return f"{head}: infeasible" + (f" ({why})" if why else "")


def draw(ax: Axes, sample: LabelledAssembly) -> None:
    """Draw one assembly into `ax`."""
    for box in sample.info.get("clamps") or []:
        if box:
            x0, y0, x1, y1 = box
            ax.add_patch(
                Rectangle(
                    (x0, y0), x1 - x0, y1 - y0, facecolor="none", edgecolor="#555", hatch="///",
                    lw=0.5,
                )
            )  # fmt: skip
    for index, part in enumerate(sample.assembly.parts):
        for x0, y0, x1, y1 in part.footprint_boxes():
            ax.add_patch(
                Rectangle(
                    (x0, y0),
                    x1 - x0,
                    y1 - y0,
                    facecolor=_COLOURS[part.type.value],
                    edgecolor="k",
                    lw=0.6,
                )
            )
        # A bracket's number goes into the free inside of its L, clear of the profiles.
        inside = 0.0 if part.type.is_profile else 0.7 * BRACKET_LEG_MM
        cx, cy = part.pose[:2, :2] @ np.array([inside, inside]) + part.pose[:2, 3]
        size = 9 if part.type.is_profile else 7
        ax.text(cx, cy, str(index), ha="center", va="center", fontsize=size, weight="bold")
        for surface in part.surfaces(index):
            nx, ny = surface.normal
            sx = surface.center[0] + nx * _SURFACE_LABEL_OFFSET_MM
            sy = surface.center[1] + ny * _SURFACE_LABEL_OFFSET_MM
            ax.text(
                sx, sy, str(surface.index), ha="center", va="center", fontsize=5, color="#7a1f1f"
            )
    ax.set_title(title(sample), fontsize=8, color="#1b5e20" if sample.truth.feasible else "#b71c1c")
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.margins(0.08)
    ax.tick_params(labelsize=6)
    ax.set_xlabel("x [mm]", fontsize=7)
    ax.set_ylabel("y [mm]", fontsize=7)


def topview_png(samples: Sequence[LabelledAssembly], columns: int = 3) -> bytes:
    """PNG bytes of a grid of top views, one panel per assembly."""
    if not samples:
        raise ValueError("topview_png needs at least one assembly")
    columns = min(columns, len(samples))
    rows = math.ceil(len(samples) / columns)
    fig = Figure(figsize=(4.2 * columns, 4.0 * rows))
    axes = fig.subplots(rows, columns, squeeze=False)
    for ax, sample in zip(axes.flat, samples, strict=False):
        draw(ax, sample)
    for ax in list(axes.flat)[len(samples) :]:
        ax.axis("off")
    fig.suptitle(
        "bold: part numbers (as in the orders); red: surface numbers; hatched: clamps",
        fontsize=9,
    )
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    return buffer.getvalue()
