"""rerun recordings of planned sequences and their failure steps (docs/recordings.md).

`write_recording(records, path)` writes one `.rrd` (rerun-sdk): per assembly, under
`/<group>/<assembly>`, the parts as 3-D boxes with their numbers, the robot cell placing each
part of the best sequence (arm links as capsules, fingers, palm and held part as boxes, clamps),
on the `step` timeline the part scores of the state, the ground-truth next parts, the predicted
top sequences, and every failure step as an error entry naming the rule and what blocks it (the
blocked part drawn red, the parts that block it orange). A blueprint gives each assembly a tab.
`summarise(path)` reads a recording back with rerun's own reader: entities, timelines, counts.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

from grace.domain.assembly import Assembly, mask_to_parts
from grace.planning.plan_views import PlanView
from grace.simulation.clearance import part_boxes
from grace.simulation.robot_cell import CellPose

APPLICATION_ID = "grace"
TIMELINE = "step"

_UNPLACED = (170, 170, 170, 70)
PLACED = (90, 130, 200, 255)
CURRENT = (60, 180, 75, 255)
BLOCKED = (220, 40, 40, 255)
BLOCKER = (245, 150, 30, 255)
CLAMP = (80, 80, 80, 200)
_TOOL = (240, 200, 60, 255)
_ARM = (235, 120, 30, 255)


def entity_root(record: PlanView, index: int) -> str:
    """`/<group>/<assembly name>` (the index when the assembly has no name)."""
    name = record.assembly.name or f"assembly_{index}"
    return f"/{record.group}/{rr.escape_entity_path_part(name)}"


def boxes_view(boxes: np.ndarray, colour: tuple, labels: list[str] | None = None) -> rr.Boxes3D:
    lo, hi = boxes[:, 0], boxes[:, 1]
    return rr.Boxes3D(mins=lo, sizes=hi - lo, colors=[colour] * len(boxes), labels=labels)


def parts_view(assembly: Assembly, placed: int, highlight: dict[int, tuple]) -> rr.Boxes3D:
    """Every part as boxes labelled with its number: placed blue, the rest grey, the parts of
    `highlight` in their own colour."""
    boxes, colours, labels = [], [], []
    for i, part in enumerate(assembly.parts):
        colour = highlight.get(i, PLACED if placed >> i & 1 else _UNPLACED)
        for k, box in enumerate(part_boxes(part)):
            boxes.append(box)
            colours.append(colour)
            labels.append(str(i) if k == 0 else "")
    lo, hi = np.array(boxes)[:, 0], np.array(boxes)[:, 1]
    return rr.Boxes3D(mins=lo, sizes=hi - lo, colors=colours, labels=labels, show_labels=True)


def log_arms(
    rec: rr.RecordingStream, root: str, pose: CellPose, links: Sequence[tuple[float, float]]
) -> None:
    """Each arm's links as capsules (MuJoCo bodies `arm<a>_l1…l4`, each link along its body's z
    axis, as in the cell's MJCF)."""
    for arm in sorted({name.split("_")[0] for name in pose.bodies}):
        segments, radii = [], []
        for k, (length, radius) in enumerate(links, 1):
            pos, rot = pose.bodies[f"{arm}_l{k}"]
            segments.append([pos, pos + rot[:, 2] * length])
            radii.append(radius)
        rec.log(
            f"{root}/cell/{arm}",
            rr.LineStrips3D(segments, radii=radii, colors=[_ARM] * len(segments)),
        )


def _sequences_markdown(record: PlanView) -> str:
    lines = [f"## {record.assembly.name or 'assembly'} ({record.assembly.n_parts} parts)", ""]
    if record.feasibility is not None:
        lines.append(f"Feasibility score (bottleneck): {record.feasibility:.4f}")
    if record.n_truth_orders is not None:
        lines.append(f"Ground truth: {record.n_truth_orders} feasible orders")
    lines += [
        "",
        "| rank | sequence | probability | simulator | failure step |",
        "|---|---|---|---|---|",
    ]
    failures = {f.rank: f for f in record.failures}
    for seq in record.plan.orders:
        check = seq.simulator
        sim = "feasible" if check.feasible else f"step {check.failing_step}: {check.rule}"
        fail = failures.get(seq.rank)
        shown = f"step {fail.step} (part {fail.part}): {fail.reason}" if fail else "-"
        order = " ".join(str(p) for p in seq.sequence)
        lines.append(f"| {seq.rank} | {order} | {seq.probability:.4g} | {sim} | {shown} |")
    if record.truth_orders:
        lines += ["", "Ground-truth orders (first ones):", ""]
        lines += [f"- {' '.join(str(p) for p in o)}" for o in record.truth_orders]
    return "\n".join(lines)


def _step_markdown(record: PlanView, step: int) -> str:
    view = record.steps[step]
    score = view.scores[view.part]
    lines = [f"step {step}: the best sequence places part {view.part} (score {score:.3f})"]
    lines.append(f"placed before: {mask_to_parts(view.placed) or 'nothing'}")
    for seq in record.plan.orders:
        lines.append(f"- rank {seq.rank} places part {seq.sequence[step]}")
    if view.truth_next is not None:
        lines.append(
            f"the ground truth lets go next: {mask_to_parts(view.truth_next) or 'nothing'}"
        )
    return "\n".join(lines)


def record_assembly(rec: rr.RecordingStream, record: PlanView, root: str) -> None:
    """Log one assembly under `root` (static tables, then the best sequence step by step)."""
    rec.log(root, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    table = rr.TextDocument(_sequences_markdown(record), media_type="text/markdown")
    rec.log(f"{root}/sequences", table, static=True)
    failures_at = {}
    for f in record.failures:
        failures_at.setdefault(f.step, []).append(f)
    top = record.failures[0] if record.failures and record.failures[0].rank == 1 else None
    for step, view in enumerate(record.steps):
        rec.set_time(TIMELINE, sequence=step)
        rec.log(
            f"{root}/cell/parts", parts_view(record.assembly, view.placed, {view.part: CURRENT})
        )
        clamps = [record.clamps[p] for p in mask_to_parts(view.placed) if p in record.clamps]
        if clamps:
            rec.log(f"{root}/cell/clamps", boxes_view(np.concatenate(clamps), CLAMP))
        else:
            rec.log(f"{root}/cell/clamps", rr.Clear(recursive=False))
        if view.pose is not None:
            log_arms(rec, root, view.pose, record.arm_links)
            rec.log(f"{root}/cell/tool", boxes_view(view.pose.tool, _TOOL))
        else:
            rec.log(f"{root}/cell/tool", rr.Clear(recursive=False))
        labels = [str(p) for p in range(record.assembly.n_parts)]
        rec.log(f"{root}/scores", rr.BarChart(view.scores, abscissa=np.arange(len(labels))))
        rec.log(f"{root}/step", rr.TextDocument(_step_markdown(record, step)))
        if top is not None and step == top.step:
            parts = record.assembly.parts
            blocked = [(top.part, BLOCKED)] + [(q, BLOCKER) for q in top.blocking]
            boxes = [(part_boxes(parts[p]), c, str(p)) for p, c in blocked]
            rec.log(
                f"{root}/cell/failure",
                rr.Boxes3D(
                    mins=np.concatenate([b[:, 0] for b, _, _ in boxes]),
                    sizes=np.concatenate([b[:, 1] - b[:, 0] for b, _, _ in boxes]),
                    colors=[c for b, c, _ in boxes for _ in b],
                    labels=[lab for b, _, lab in boxes for _ in b],
                    radii=2.0,
                ),
            )
        elif top is not None and step == top.step + 1:
            rec.log(f"{root}/cell/failure", rr.Clear(recursive=False))
        for f in failures_at.get(step, []):
            text = f"rank {f.rank}, step {f.step}: part {f.part} {f.where}; {f.reason}"
            rec.log(f"{root}/failures", rr.TextLog(text, level="ERROR"))


def assembly_tabs(roots: list[str]) -> list[rrb.Horizontal]:
    """One tab per assembly: the cell in 3-D, the part scores, the step text, the failure log
    and the sequence table side by side."""
    return [
        rrb.Horizontal(
            rrb.Spatial3DView(origin=f"{root}/cell", name="cell"),
            rrb.Vertical(
                rrb.BarChartView(origin=f"{root}/scores", name="part scores"),
                rrb.TextDocumentView(origin=f"{root}/step", name="step"),
                rrb.TextLogView(origin=f"{root}/failures", name="failures"),
                rrb.TextDocumentView(origin=f"{root}/sequences", name="sequences"),
            ),
            name=root.strip("/"),
        )
        for root in roots
    ]


@contextmanager
def recording_stream(path: str | Path, name: str) -> Iterator[rr.RecordingStream]:
    """A rerun stream into the `.rrd` at `path`: written beside it, renamed into place when the
    block ends without error (nothing half-written otherwise)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=name)
    try:
        rec.save(tmp)
        rec.set_log_time_enabled(False)  # our timelines only: same input, same file
        yield rec
        rec.flush()
        rec.disconnect()
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_recording(records: Sequence[PlanView], path: str | Path, name: str) -> Path:
    """Write `records` into the `.rrd` at `path` (atomically, `recording_stream`)."""
    with recording_stream(path, name) as rec:
        roots = [entity_root(r, i) for i, r in enumerate(records)]
        for record, root in zip(records, roots, strict=True):
            record_assembly(rec, record, root)
        rec.send_blueprint(rrb.Blueprint(rrb.Tabs(*assembly_tabs(roots)), collapse_panels=False))
    return Path(path)


@dataclass
class EntitySummary:
    """What one entity of a recording holds: its rows, timelines and whether it is static."""

    rows: int = 0
    timelines: set[str] = field(default_factory=set)
    static: bool = False


@dataclass
class RecordingSummary:
    """Entities, timelines and the `step` range of one `.rrd`."""

    path: Path
    entities: dict[str, EntitySummary]
    steps: tuple[int, int] | None

    def lines(self) -> list[str]:
        roots = {e.rsplit("/", 1)[0] for e in self.entities if e.endswith("/sequences")}
        failures = sum(s.rows for e, s in self.entities.items() if e.endswith("/failures"))
        timelines = sorted({t for s in self.entities.values() for t in s.timelines})
        out = [
            f"{self.path}: {len(roots)} assemblies, {len(self.entities)} entities, "
            f"timelines {timelines}, steps {self.steps}, {failures} failure entries",
        ]
        out += [
            f"  {e}: {s.rows} rows" + (" (static)" if s.static else f" on {sorted(s.timelines)}")
            for e, s in sorted(self.entities.items())
        ]
        return out


def summarise(path: str | Path) -> RecordingSummary:
    """Read a recording back with rerun's reader (rerun.chunk.RrdReader)."""
    entities: dict[str, EntitySummary] = {}
    lo, hi = None, None
    for chunk in RrdReader(path).stream():
        if chunk.entity_path.startswith("/__"):
            continue
        entry = entities.setdefault(chunk.entity_path, EntitySummary())
        entry.rows += chunk.num_rows
        entry.static = entry.static or chunk.is_static
        entry.timelines.update(t for t in chunk.timeline_names if t != "log_time")
        if TIMELINE in chunk.timeline_names:
            steps = chunk.to_record_batch().column(TIMELINE).to_pylist()
            lo = min([*steps, *([lo] if lo is not None else [])])
            hi = max([*steps, *([hi] if hi is not None else [])])
    return RecordingSummary(Path(path), entities, None if lo is None else (lo, hi))


def text_entries(path: str | Path, suffix: str) -> list[tuple[str, int | None, str]]:
    """(entity, step, text) of every text logged to an entity ending in `suffix` (e.g.
    "/failures"), in file order."""
    out = []
    for chunk in RrdReader(path).stream():
        if not chunk.entity_path.endswith(suffix):
            continue
        batch = chunk.to_record_batch()
        column = next(n for n in batch.schema.names if n.endswith(":text"))
        steps = (
            batch.column(TIMELINE).to_pylist()
            if TIMELINE in batch.schema.names
            else [None] * batch.num_rows
        )
        for step, texts in zip(steps, batch.column(column).to_pylist(), strict=True):
            out.extend((chunk.entity_path, step, t) for t in texts or [])
    return out


def open_viewer(path: str | Path) -> bool:
    """Open `path` in the rerun viewer if a display exists; False (nothing started) otherwise."""
    if not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY") or sys.platform == "darwin"
    ):
        return False
    subprocess.Popen([sys.executable, "-m", "rerun", str(path)], start_new_session=True)
    return True
