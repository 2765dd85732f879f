"""`python -m grace task=search_bench ckpt=<run folder or .ckpt>`: the verified search against
its baselines, under one budget of simulator step checks (docs/planning.md).

Labelled test assemblies (`task.sizes`, data seed `task.data_seed`, generated and cached by the
data store like any data set) are planned by every planner of `task.planners`, each with a
fresh step-check cache: the search of `planner=` ordered by the kept model (`grace`), the same
search ordered by the contact heuristic (`heuristic`) and by random part order with and without
learnt blocks (`dfs_blocks`, `dfs`: uninformed depth-first search), the network without
verification (`grace_unverified`: its most probable sequence, then checked) and the ground
truth's brute force (`brute_force`). Larger unlabelled assemblies (`task.large_sizes`, no brute
force there) are planned by `task.large_planners` under the planner's own budget; with
`task.large_feasible=true` they are drawn with a verified order (grace/planning/
feasible_frames.py) and summarised as feasible ones. Writes
search_bench.json (per assembly and summarised per size, grace/evaluation/search_bench.py), its
tables as search_bench.md and search_bench.png; returns the GRACE search's success rate at 2N
checks on the largest labelled size.
"""

from __future__ import annotations

import gc
import json
import logging
import resource
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig, OmegaConf

from grace.cli.runner import TaskSettings
from grace.data.atomic import write_text_atomic
from grace.data.store import GeneratedSource, assembly_rng
from grace.errors import UserError
from grace.evaluation.search_bench import (
    AssemblyRuns,
    planner_set,
    run_planners,
    search_bench_markdown,
    summarise,
    summary_line,
)
from grace.model.checkpoints import load_model
from grace.model.kept import find_checkpoint
from grace.model.scoring import make_scorer
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.feasible_frames import FeasibleFrames
from grace.planning.search import Outcome, VerifiedSearch
from grace.roles import PLANNING, RUN
from grace.visualisation.search_plots import search_bench_plot

log = logging.getLogger(__name__)


@dataclass
class SearchBenchSettings(TaskSettings):
    """Schema of `task=search_bench` (values in grace/conf/task/search_bench.yaml)."""

    # a run folder (train or experiment) or a .ckpt file
    ckpt: str | None = field(default=MISSING, metadata=PLANNING)
    # which fold's model of an experiment run folder
    fold: int = field(default=0, metadata=PLANNING)
    # size → labelled test assemblies
    sizes: Any = field(default=MISSING, metadata=PLANNING)
    # what `sizes` interpolates unless overridden whole
    default_sizes: Any = field(default=None, metadata=PLANNING)
    # their data seed (not the training data's)
    data_seed: int = field(default=MISSING, metadata=PLANNING)
    # size → unlabelled assemblies (no brute force)
    large_sizes: Any = field(default=None, metadata=PLANNING)
    default_large_sizes: Any = field(default=None, metadata=PLANNING)
    # draw them feasible (grace/planning/feasible_frames.py)
    large_feasible: bool = field(default=False, metadata=PLANNING)
    # torch threads of this task: the root `threads` follows it unless given
    threads: int = field(default=1, metadata=RUN)
    planners: list[str] = field(default=MISSING, metadata=PLANNING)
    large_planners: list[str] = field(default=MISSING, metadata=PLANNING)
    # multiples of N
    budgets: list[int] = field(default=MISSING, metadata=PLANNING)
    # per planner and labelled assembly
    max_seconds: float | None = field(default=MISSING, metadata=PLANNING)
    reference: str = field(default="dfs", metadata=PLANNING)
    # grace.planning.heuristics.ContactHeuristic
    heuristic: Any = field(default=MISSING, metadata=PLANNING)
    # the unverified top-1's best-first bound
    unverified_max_expansions: int | None = field(default=None, metadata=PLANNING)


def run(cfg: DictConfig) -> float | None:
    out_dir = Path(cfg.paths.output_dir)
    task = cfg.task
    search = instantiate(cfg.planner)
    if not isinstance(search, VerifiedSearch):
        raise UserError(
            f"planner={OmegaConf.select(cfg, 'planner._target_')} is not a verified search; "
            "fix: task=search_bench measures planner=verified (drop planner=topk)"
        )
    module, _ = load_model(find_checkpoint(task.ckpt, int(task.fold)))
    scorer = make_scorer(module)
    simulator = instantiate(cfg.simulator)
    heuristic = instantiate(task.heuristic).scorer()
    data = OmegaConf.to_container(cfg.dataset, resolve=True)  # sizes replaced, not merged
    data.update(sizes=OmegaConf.to_container(task.sizes), seed=int(task.data_seed))
    source = instantiate(data)
    if not isinstance(source, GeneratedSource):
        raise UserError("task=search_bench generates its test assemblies; fix: dataset=generated")
    bench = replace(search, k=1, max_checks=None, max_seconds=task.max_seconds)
    names = list(task.planners)
    expansions = task.unverified_max_expansions
    planners = planner_set(names, bench, scorer, heuristic, int(cfg.seed), expansions)
    oracle = lambda assembly: SimulatorSteps(simulator, assembly)  # noqa: E731
    samples = source.load()
    gc.freeze()  # the loaded objects stay out of full collections (grace/tasks/plan.py)
    begin = time.perf_counter()
    records: list[AssemblyRuns] = []
    disagreements = []
    for sample in samples:
        truth = sample.truth
        runs = run_planners(sample.assembly, planners, oracle)
        for name, got in runs.items():
            wrong = (got.outcome == Outcome.verified and not truth.feasible) or (
                got.outcome == Outcome.infeasible and truth.feasible
            )
            if wrong:
                disagreements.append({"assembly": sample.assembly.name, "planner": name})
        records.append(
            AssemblyRuns(sample.assembly.name, sample.size, truth.feasible, truth.checks, runs)
        )
        if len(records) % 25 == 0:
            log.info("%d assemblies planned (%.0f s)", len(records), time.perf_counter() - begin)
    if disagreements:
        log.error("verdicts that contradict the ground truth: %s", disagreements)
    large = planner_set(
        list(task.large_planners), replace(search, k=1), scorer, heuristic, 0, expansions
    )
    max_parts = int(OmegaConf.select(cfg, "simulator.cell.max_parts", default=0) or 0)
    skipped = {}
    frames = FeasibleFrames(replace(search, k=1), heuristic) if task.large_feasible else None
    for size, count in sorted((int(k), int(v)) for k, v in (task.large_sizes or {}).items()):
        if max_parts and size > max_parts:
            skipped[size] = f"simulator.cell.max_parts={max_parts}"
            log.warning("A%d skipped: raise simulator.cell.max_parts to %d", size, size)
            continue
        for index in range(count):
            rng = assembly_rng(int(task.data_seed), size, index)
            assembly = (
                frames.draw(simulator, size, rng) if frames else simulator.generate(size, rng)
            )
            assembly.name = f"A{size}-{index:06d}"
            runs = run_planners(assembly, large, oracle)
            feasible = True if frames else None  # a drawn frame has a verified order
            records.append(AssemblyRuns(assembly.name, size, feasible, None, runs))
            log.info("%s planned (%.0f s)", assembly.name, time.perf_counter() - begin)
    seconds = time.perf_counter() - begin
    summary = summarise(records, list(task.budgets), task.reference)
    result = {
        "checkpoint": str(find_checkpoint(task.ckpt, int(task.fold))),
        "planner": OmegaConf.to_container(cfg.planner, resolve=True),
        "budgets": [f"{b}N" for b in task.budgets] + ["unlimited"],
        "max_seconds": task.max_seconds,
        "data_seed": int(task.data_seed),
        "seconds": seconds,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "skipped_sizes": skipped,
        "disagreements": disagreements,
        "summary": summary,
        "assemblies": [r.to_json() for r in records],
    }
    write_text_atomic(out_dir / "search_bench.json", json.dumps(result, indent=2) + "\n")
    write_text_atomic(out_dir / "search_bench.md", search_bench_markdown(summary))
    search_bench_plot(summary, out_dir / "search_bench.png")
    budgets = " ".join(f"{b:>5}" for b in result["budgets"])
    print(f"size class      planner           {budgets}  checks      s  (medians)")
    for size, entry in summary.items():
        for kind in ("feasible", "infeasible"):
            for name, figures in entry.get(kind, {}).get("planners", {}).items():
                print(summary_line(size, kind, name, figures))
        for name, figures in entry.get("unlabelled", {}).get("planners", {}).items():
            print(f"A{size:<3} unlabelled {name:<17} {figures['outcomes']}, "
                  f"max {figures['max_seconds']:.2f} s")  # fmt: skip
    print(
        f"{len(records)} assemblies in {seconds:.0f} s, peak memory {result['peak_rss_mb']:.0f} MB;"
        f" search_bench.json, .md and .png in {out_dir}"
    )
    largest = max((s for s, e in summary.items() if "feasible" in e), key=int, default=None)
    if largest is None or "grace" not in names:
        return None
    return summary[largest]["feasible"]["planners"]["grace"]["success"].get("2N")
