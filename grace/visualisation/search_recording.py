"""plan.rrd of a verified search: how the search went, and the verified order in the cell.

The plan (grace/planning/plans.py) holds the search's first events, each refusal with the
simulator's reason, and grace/planning/plan_views.py the cell's poses along the verified order,
both gathered where the simulator lives; the writer only draws them. It logs, under
`/plan/<assembly>` (docs/recordings.md):

- on the `check` timeline, one row per search event (a step the checks accepted, a step they
  refused, a state ruled out by a learnt block): the parts placed in that state, the part tried
  (green: placed, red: refused or ruled out) and the parts that block it (orange), and a log
  line naming the rule and what blocks it;
- the search tree (states, verified steps, refused candidates) as a graph, and a summary;
- on the `step` timeline, the verified order replayed with both arms, exactly as an
  experiment's sequences.rrd shows a sequence (grace/visualisation/recording.py).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from grace.domain.assembly import mask_to_parts
from grace.planning.plan_views import PlanView
from grace.visualisation.recording import (
    BLOCKED,
    BLOCKER,
    CLAMP,
    CURRENT,
    PLACED,
    assembly_tabs,
    boxes_view,
    entity_root,
    parts_view,
    record_assembly,
    recording_stream,
    write_recording,
)

SEARCH_TIMELINE = "check"


def _summary_markdown(record: PlanView) -> str:
    assembly, plan, search = record.assembly, record.plan, record.plan.search
    rules = Counter(s.rule for s in search.events if s.kind == "refused")
    kinds = Counter(s.kind for s in search.events)
    lines = [
        f"## {assembly.name or 'assembly'} ({assembly.n_parts} parts): {plan.outcome}",
        "",
        f"{search.checks} simulator step checks in {plan.seconds:.2f} s; "
        f"{search.expanded} states scored by the policy",
    ]
    if search.first_checks is not None:
        lines.append(f"first verified order after {search.first_checks} checks")
    lines += [
        "",
        f"events: {kinds['placed']} steps taken, {kinds['refused']} refused, "
        f"{kinds['ruled_out']} states ruled out"
        + (
            f" (the first {len(search.events)} of {search.n_events} shown)"
            if search.n_events > len(search.events)
            else ""
        ),
        "",
        "refusals by rule: " + (", ".join(f"{r}: {c}" for r, c in rules.most_common()) or "none"),
        "",
        "| rank | verified order | probability |",
        "|---|---|---|",
    ]
    for ranked in plan.orders:
        order = " ".join(str(p) for p in ranked.sequence)
        lines.append(f"| {ranked.rank} | {order} | {ranked.probability:.4g} |")
    return "\n".join(lines)


def _tree(record: PlanView) -> tuple[rr.GraphNodes, rr.GraphEdges]:
    """States (blue), the complete assembly (green) and refused candidates (red), linked by
    the steps tried."""
    full = (1 << record.assembly.n_parts) - 1
    nodes: dict[str, tuple[str, tuple]] = {"0": ("∅", PLACED)}
    edges = []
    for step in record.plan.search.events:
        if step.kind == "ruled_out":
            continue
        if step.kind == "placed":
            child = step.state | 1 << step.part
            target = f"{child:x}"
            nodes.setdefault(target, (f"+{step.part}", CURRENT if child == full else PLACED))
        else:
            target = f"{step.state:x}x{step.part}"
            nodes[target] = (f"✗{step.part}", BLOCKED)
        edges.append((f"{step.state:x}", target))
    ids = list(nodes)
    return (
        rr.GraphNodes(ids, labels=[nodes[i][0] for i in ids], colors=[nodes[i][1] for i in ids]),
        rr.GraphEdges(edges, graph_type="directed"),
    )


def log_search(rec: rr.RecordingStream, record: PlanView, root: str) -> None:
    """The search under `root` (static summary and tree, then one row per event)."""
    rec.log(root, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    rec.log(
        f"{root}/summary",
        rr.TextDocument(_summary_markdown(record), media_type="text/markdown"),
        static=True,
    )
    nodes, edges = _tree(record)
    rec.log(f"{root}/tree", nodes, edges, static=True)
    clamps = record.clamps
    level = {"placed": "INFO", "refused": "WARN", "ruled_out": "DEBUG"}
    for index, step in enumerate(record.plan.search.events):
        rec.set_time(SEARCH_TIMELINE, sequence=index)
        colour = CURRENT if step.kind == "placed" else BLOCKED
        highlight = {q: BLOCKER for q in step.blocking} | {step.part: colour}
        rec.log(f"{root}/cell/parts", parts_view(record.assembly, step.state, highlight))
        placed = [clamps[p] for p in mask_to_parts(step.state) if p in clamps]
        if placed:
            rec.log(f"{root}/cell/clamps", boxes_view(np.concatenate(placed), CLAMP))
        else:
            rec.log(f"{root}/cell/clamps", rr.Clear(recursive=False))
        text = (
            f"check {step.checks}: placed {mask_to_parts(step.state) or 'nothing'}, "
            f"part {step.part}: {step.reason}"
        )
        rec.log(f"{root}/log", rr.TextLog(text, level=level[step.kind]))


def write_search_recording(record: PlanView, path: str | Path, name: str) -> Path:
    """plan.rrd: the search and the verified order (module docstring), written atomically."""
    root = entity_root(record, 0)
    with recording_stream(path, name) as rec:
        record_assembly(rec, record, root)
        log_search(rec, record, f"{root}/search")
        search_tab = rrb.Horizontal(
            rrb.Spatial3DView(origin=f"{root}/search/cell", name="search: cell"),
            rrb.Vertical(
                rrb.GraphView(origin=f"{root}/search/tree", name="search tree"),
                rrb.TextLogView(origin=f"{root}/search/log", name="checks"),
                rrb.TextDocumentView(origin=f"{root}/search/summary", name="summary"),
            ),
            name="search",
        )
        tabs = rrb.Tabs(search_tab, *assembly_tabs([root]))
        rec.send_blueprint(rrb.Blueprint(tabs, collapse_panels=False))
    return Path(path)


def write_plan_recording(record: PlanView, path: str | Path, name: str) -> Path:
    """plan.rrd of either planner's plan: the search and its order when it searched (a verified
    search), else its listed sequences as an experiment's sequences.rrd shows them."""
    if record.plan.search is not None:
        return write_search_recording(record, path, name)
    return write_recording([record], path, name)
