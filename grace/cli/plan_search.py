"""`task=plan` with the verified search (`planner=verified`, the default; docs/planning.md).

The policy orders the steps, the simulator checks each before it is taken: the user gets
verified orders first, each with the network's probability and the simulator's verdict on every
step, or "infeasible" (every order refuted) or "not found within budget", never an order the
simulator refuses. Writes plan.json and prints the answer, then (`task.recording=true`) plan.rrd:
the search and the verified order in the cell.
"""

from __future__ import annotations

import gc
import json
import logging
import time
from collections import Counter
from dataclasses import asdict
from pathlib import Path
from typing import Any

from grace.data.atomic import write_text_atomic
from grace.domain.assembly import Assembly, mask_to_parts
from grace.domain.orders import GroundTruth
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.search import Outcome, VerifiedSearch
from grace.planning.sequences import Scorer
from grace.planning.topk import FULL_TABLE_MAX_PARTS, lazy_scores
from grace.simulation.simulator import Simulator
from grace.visualisation.records import SearchRecord, search_record, with_cell

log = logging.getLogger(__name__)

REFUSALS_LISTED = 20
"""Refused steps listed in plan.json (all are counted, by rule)."""


def _in_truth(truth: GroundTruth | None, order: tuple[int, ...]) -> bool | None:
    """Whether `order` is one of the raw folder's ground-truth orders (None: none given)."""
    if truth is None:
        return None
    state = 0
    for part in order:
        try:
            if not truth.label(state) >> part & 1:
                return False
        except KeyError:
            return False
        state |= 1 << part
    return True


def order_entry(
    rank: int, ranked: Any, check: Any, names: list[str], ground_truth: bool | None
) -> dict[str, Any]:
    """One order of plan.json (either planner): its parts, the network's probability and step
    scores, the simulator's verdict per step, and whether the raw folder's ground truth holds it
    (null: none given)."""
    return {
        "rank": rank,
        "sequence": list(ranked.sequence),
        "parts": [names[p] for p in ranked.sequence],
        "probability": ranked.probability,
        "step_scores": list(ranked.step_scores),
        "simulator": {
            "feasible": check.feasible,
            "verdicts": [v.feasible for v in check.verdicts],
        },
        "ground_truth": ground_truth,
    }


def verified_json(
    record: SearchRecord, planner: VerifiedSearch, truth: GroundTruth | None, sources: dict
) -> dict[str, Any]:
    """plan.json of a verified search: the outcome, what it cost, the verified orders (each
    step's verdict) and the refused steps with their reasons."""
    assembly = record.order.assembly
    names = [p.name for p in assembly.parts]
    orders = [
        order_entry(rank, ranked, check, names, _in_truth(truth, ranked.sequence))
        for rank, (ranked, check) in enumerate(
            zip(record.order.ranked, record.order.checks, strict=True), 1
        )
    ]
    refused = [s for s in record.steps if s.kind == "refused"]
    proof = {}
    if record.unplaceable is not None:
        part = record.unplaceable
        proof = {
            "proof": {
                "part": part,
                "name": names[part],
                "reason": (
                    f"no order can place part {part} ({names[part]}): the precedences every "
                    "order must keep leave it without a usable option, or force it before "
                    "itself (docs/planning.md, 'Infeasibility without a search')"
                ),
            }
        }
    return {
        **sources,
        "planner": asdict(planner),  # StrEnum values serialise as their names
        "name": assembly.name,
        "n_parts": assembly.n_parts,
        "outcome": record.outcome,
        "checks": record.checks,
        "first_checks": record.first_checks,
        "expanded": record.expanded,
        "orders": orders,
        "refused": {
            "count": len(refused),
            "by_rule": dict(Counter(s.rule for s in refused).most_common()),
            "first": [
                {
                    "placed": mask_to_parts(s.state),
                    "part": s.part,
                    "rule": s.rule,
                    "blocking_parts": list(s.blocking),
                    "reason": s.reason,
                }
                for s in refused[:REFUSALS_LISTED]
            ],
        },
        **proof,
    }


def plan_verified(
    planner: VerifiedSearch,
    assembly: Assembly,
    truth: GroundTruth | None,
    scorer: Scorer,
    simulator: Simulator,
    sources: dict[str, Any],
    out_dir: Path,
    recording: bool,
) -> None:
    """Search `assembly`, write plan.json into `out_dir` and print the result; then, with
    `recording`, plan.rrd."""
    n = assembly.n_parts
    if n > FULL_TABLE_MAX_PARTS and planner.max_checks is None and planner.max_seconds is None:
        log.warning(
            "%d parts and no budget: the search may run long before it proves the assembly "
            "infeasible; set planner.max_seconds or planner.max_checks",
            n,
        )
    # What is loaded (torch, MuJoCo, Hydra: about a million objects) never becomes garbage;
    # frozen, it stays out of the collector's full walks, which the search's many small
    # allocations would otherwise trigger dozens of times (tens of ms each).
    gc.freeze()
    start = time.perf_counter()
    oracle = SimulatorSteps(simulator, assembly)
    result = planner.plan(scorer, assembly, oracle)
    seconds = time.perf_counter() - start
    scores = lazy_scores(scorer, assembly)
    record = search_record("plan", result, scores, oracle, truth, cell=False)
    timing = {
        "seconds": seconds,  # the search: scoring, step checks, the cell queries (model loaded)
        "first_seconds": result.first_seconds,
        "record_seconds": time.perf_counter() - start - seconds,  # the refusals' reasons
    }
    out = verified_json(record, planner, truth, {**sources, **timing})
    write_text_atomic(out_dir / "plan.json", json.dumps(out, indent=2) + "\n")
    cost = f"{result.checks} simulator step checks, {seconds:.2f} s"
    if result.outcome == Outcome.verified:
        print(f"{assembly.name}: {n} parts, {len(result.orders)} verified order(s) ({cost})")
    elif result.outcome == Outcome.infeasible:
        print(f"{assembly.name}: {n} parts, infeasible: every order refuted ({cost})")
    else:
        print(
            f"{assembly.name}: {n} parts, not found within budget (planner.max_checks="
            f"{planner.max_checks}, planner.max_seconds={planner.max_seconds}; {cost})"
        )
    for entry in out["orders"]:
        order = " ".join(str(p) for p in entry["sequence"])
        verdict = "every step feasible" if entry["simulator"]["feasible"] else "REFUSED"
        print(f"{entry['rank']:3d}. {order}  p={entry['probability']:.4g}  simulator: {verdict}")
    print(f"loading {sources['load_seconds']:.2f} s; plan.json in {out_dir}", flush=True)
    if recording:
        # rerun loads only to record; the cell's poses are drawn, never answered
        from grace.visualisation.search_recording import write_search_recording

        record.order = with_cell(record.order, scores, oracle.checker, truth)
        write_search_recording(record, out_dir / "plan.rrd", out_dir.name)
        print(f"plan.rrd in {out_dir}")
