"""`python -m grace task=plan ckpt=<run folder or .ckpt> assembly=<raw folder or assembly.spec>`.

Plans one assembly with a kept model (docs/recordings.md, "Planning an assembly"): the `k` most
probable complete sequences, best first (Algorithm 1's scores over distinct states, then
best-first top-k, grace/planning/topk.py), each with its probability and step scores, the
assembly's feasibility score (the bottleneck: the largest λ at which Algorithm 1 still finds a
sequence, docs/metrics.md), and every listed sequence checked step by step in the simulator the
model was trained with (verdict; at the first failing step the deciding rule and what blocks
it). Writes plan.json into the run folder and prints the answer; with `task.recording=true`,
plan.rrd after it (rerun is imported only then). Planning imports neither Lightning nor PyG
(grace/model/checkpoints.py).

The model is rebuilt from the `config.yaml` kept beside its checkpoint (<fold>/config.yaml, see
grace/model/checkpoints.py), and the checkpoint's weights must fit it exactly: a checkpoint made for
another config stops with one line naming both files.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig

from grace.cli.plan_search import order_entry, plan_verified
from grace.cli.runner import TaskSettings
from grace.data.atomic import write_json_atomic
from grace.data.raw_format import read_assembly
from grace.model.checkpoints import load_model
from grace.model.kept import find_checkpoint
from grace.model.scoring import make_scorer
from grace.planning.topk import FULL_TABLE_MAX_PARTS, rank_sequences
from grace.roles import PLANNING
from grace.simulation.check import OrderChecker, blockers, describe
from grace.visualisation.records import SequenceRecord, ranked_record, with_cell

log = logging.getLogger(__name__)


@dataclass
class PlanSettings(TaskSettings):
    """Schema of `task=plan` (values in grace/conf/task/plan.yaml)."""

    reads: ClassVar[tuple[str, ...] | None] = ("planner",)
    # a run folder (train or experiment) or a .ckpt file
    ckpt: str | None = field(default=MISSING, metadata=PLANNING)
    # a raw assembly folder or an assembly.spec file
    assembly: str | None = field(default=MISSING, metadata=PLANNING)
    # which fold's model of an experiment run folder
    fold: int = field(default=0, metadata=PLANNING)
    # plan.rrd too, written after plan.json and the printed answer
    recording: bool = field(default=False, metadata=PLANNING)
    # the model's training cell; false: `simulator=` (e.g. large_frames)
    kept_world: bool = field(default=True, metadata=PLANNING)


def plan_json(record: SequenceRecord, sources: dict[str, Any]) -> dict[str, Any]:
    """plan.json: the listed sequences with probabilities, step scores and simulator checks."""
    names = [p.name for p in record.assembly.parts]
    outside = {f.rank for f in record.failures}
    known = record.n_truth_orders is not None
    sequences = []
    for rank, (seq, check) in enumerate(zip(record.ranked, record.checks, strict=True), 1):
        failure = check.failure
        entry = order_entry(rank, seq, check, names, rank not in outside if known else None)
        entry["simulator"].update(
            failing_step=check.failing_step,
            rule=failure.rule if failure else None,
            blocking_parts=sorted({b.part for b in blockers(failure) if b.part is not None})
            if failure
            else [],
            reason=describe(failure, names) if failure else None,
        )
        sequences.append(entry)
    return {
        **sources,
        "name": record.assembly.name,
        "n_parts": record.assembly.n_parts,
        "feasibility": record.feasibility,
        "ground_truth_orders": record.n_truth_orders,
        "sequences": sequences,
    }


def run(cfg: DictConfig) -> float | None:
    """Plan `task.assembly` with the model of `task.ckpt`; return its feasibility score."""
    out_dir = Path(cfg.paths.output_dir)
    begin = time.perf_counter()
    ckpt = find_checkpoint(cfg.task.ckpt, int(cfg.task.fold))
    assembly, truth = read_assembly(cfg.task.assembly)
    module, kept = load_model(ckpt)
    simulator = instantiate(kept.simulator if cfg.task.kept_world else cfg.simulator)
    planner = instantiate(cfg.planner)
    start = time.perf_counter()
    load_seconds = start - begin
    sources = {"checkpoint": str(ckpt), "assembly": str(cfg.task.assembly)}
    recording = bool(cfg.task.recording)
    if planner.verify:  # the default: grace/cli/plan_search.py
        sources["load_seconds"] = load_seconds
        scorer = make_scorer(module)
        plan_verified(planner, assembly, truth, scorer, simulator, sources, out_dir, recording)
        return None
    budget = f"planner.max_expansions={planner.max_expansions}, planner.max_seconds="
    budget += f"{planner.max_seconds}"
    if assembly.n_parts > FULL_TABLE_MAX_PARTS:
        log.warning(
            "%d parts: the top-k listing scores states lazily without completion bounds and "
            "stops at %s; planner=verified is the bounded planner", assembly.n_parts, budget,
        )  # fmt: skip
    ranking = rank_sequences(
        make_scorer(module), assembly, planner.k, planner.threshold, planner.max_expansions,
        planner.max_seconds,
    )  # fmt: skip
    checker = OrderChecker(simulator, assembly)
    record = ranked_record(
        "plan", ranking.ranked, ranking.scores, checker, truth, planner.k, ranking.feasibility,
        cell=False,
    )  # fmt: skip
    seconds = time.perf_counter() - start
    sources["seconds"] = seconds  # scoring, top-k and simulator checks (model loaded)
    sources["load_seconds"] = load_seconds  # checkpoint, config, assembly, simulator
    sources["stopped_by_budget"] = ranking.stopped
    result = plan_json(record, {**sources, "k": planner.k, "threshold": planner.threshold})
    write_json_atomic(out_dir / "plan.json", result)
    feas = "n/a" if record.feasibility is None else f"{record.feasibility:.4f}"
    print(f"{assembly.name}: {assembly.n_parts} parts, feasibility score {feas}")
    for entry in result["sequences"]:
        sim = entry["simulator"]
        verdict = "feasible"
        if not sim["feasible"]:
            step = sim["failing_step"]  # 0-based in plan.json, 1-based for reading
            part = entry["sequence"][step]
            verdict = f"fails at step {step + 1} (part {part}): {sim['reason']}"
        order = " ".join(str(p) for p in entry["sequence"])
        print(f"{entry['rank']:3d}. {order}  p={entry['probability']:.4g}  simulator: {verdict}")
    if ranking.stopped:
        print(f"{len(ranking.ranked)} of {planner.k} sequences found within budget ({budget})")
    elif not result["sequences"]:
        print(f"no complete sequence has every step scoring ≥ {planner.threshold}")
    print(
        f"planned and checked in {seconds:.2f} s (loading {load_seconds:.2f} s); "
        f"plan.json in {out_dir}",
        flush=True,
    )
    if recording:
        from grace.visualisation.recording import write_recording  # rerun: only to record

        record = with_cell(record, ranking.scores, checker, truth)
        write_recording([record], out_dir / "plan.rrd", out_dir.name)
        print(f"plan.rrd in {out_dir}")
    return record.feasibility
