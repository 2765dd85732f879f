"""`python -m grace` (task=experiment): cross-validated training, planning and evaluation.

For each fold of the chosen protocol (docs/protocols.md) it trains one model, plans every test
assembly with Algorithm 1 over distinct states and computes the metrics of docs/metrics.md per
test size, for GRACE, for the baselines and for the floors on the same test assemblies. Writes
results.json, results.md, pr_curves.png, p_at_k.png, failures.json and failures.png into the run
folder, flags collapsed folds, and returns the mean sequence AUC over the test sizes (the sweep
objective).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig, OmegaConf
from pydantic import TypeAdapter

from grace.cli.fit import fold_module
from grace.cli.folds import protocol_folds, run_folds, start_fold
from grace.cli.progress import FoldReporter
from grace.cli.runner import TaskSettings, task_overrides
from grace.domain.sample import LabelledAssembly
from grace.evaluation.baselines import BASELINES
from grace.evaluation.collapse import fold_health
from grace.evaluation.evaluate import evaluate_by_size
from grace.evaluation.feasibility_schemes import add_schemes, embedding_schemes
from grace.evaluation.protocols import Fold, training_subset
from grace.evaluation.report import aggregate, mean_curves, write_results
from grace.evaluation.results import (
    ExperimentResults,
    FoldHealth,
    PolicyResults,
    RunInfo,
    StageSeconds,
)
from grace.evaluation.side_files import write_side_files
from grace.planning.plan_views import PlanView, fold_views
from grace.planning.sequences import Scorer
from grace.roles import PLANNING, RUN, WEIGHTS
from grace.visualisation.plots import p_at_k_bars, pr_curves
from grace.visualisation.recording import write_recording
from grace.visualisation.records import RecordingSettings
from grace.visualisation.side_file_plots import draw_side_files

log = logging.getLogger(__name__)
# every heavy group but `planner` and `tune`: the verified search plans nothing here
READS = ("model", "datamodule", "trainer", "callbacks", "logger", "threshold")


@dataclass
class ExperimentSettings(TaskSettings):
    """Schema of `task=experiment` (values in grace/conf/task/experiment.yaml)."""

    reads: ClassVar[tuple[str, ...] | None] = READS
    # (cfg, train, val, out_dir, callbacks) -> trained module, a partial
    fit: Any = field(default=MISSING, metadata=WEIGHTS)
    # (module) -> Scorer, a partial
    scorer: Any = field(default=MISSING, metadata=PLANNING)
    threshold: float = field(default=MISSING, metadata=PLANNING)
    ks: list[int] = field(default=MISSING, metadata=PLANNING)
    baselines: list[str] = field(default=MISSING, metadata=PLANNING)
    # train on feasible assemblies only (training_subset)
    train_feasible_only: bool = field(default=MISSING, metadata=WEIGHTS)
    fold_jobs: int = field(default=MISSING, metadata=RUN)
    # a run folder: plan its folds' kept models, train none
    checkpoints: str | None = field(default=None, metadata=PLANNING)
    # sequences.rrd
    recording: RecordingSettings = field(default_factory=RecordingSettings, metadata=PLANNING)


def _policies(cfg: DictConfig, module: object, fold: Fold) -> dict[str, Scorer]:
    """GRACE from the trained module plus every baseline of `task.baselines`, seeded per fold,
    each planned under the `threshold` rule (docs/metrics.md: the paper's λ, lifted or relative)."""
    unknown = sorted(set(cfg.task.baselines) - set(BASELINES))
    if unknown:
        raise ValueError(f"task.baselines: unknown {unknown}; choose from {sorted(BASELINES)}")
    policies = {"GRACE": instantiate(cfg.task.scorer)(module)}
    policies.update({b: BASELINES[b](cfg.seed + fold.index) for b in cfg.task.baselines})
    rule = instantiate(cfg.threshold)
    return {name: rule(scorer) for name, scorer in policies.items()}


@dataclass
class FoldResult:
    """Metrics of every policy on one fold's test assemblies, and the stage times."""

    metrics: dict[str, dict[int, dict]]
    train_s: float
    evaluate_s: float
    health: dict
    records: list[PlanView]


def run_fold(
    cfg: DictConfig,
    fold: Fold,
    train: list[LabelledAssembly],
    val: list[LabelledAssembly],
    test: list[LabelledAssembly],
    threads: int,
    progress: FoldReporter,
    parent: int,
) -> FoldResult:
    """Train on one fold and evaluate GRACE and the baselines on its test assemblies.

    Seeded by `seed + fold index`, so a fold's result does not depend on which folds ran
    before it or in which process. In a worker process (not `parent`) all messages go to the
    run's log file; the parent shows the fold's progress from `progress`.
    """
    start_fold(cfg, fold, threads, parent)
    log.info(
        "fold %d: train %d, val %d, test %d assemblies",
        *(fold.index, len(train), len(val), len(test)),
    )
    tick = time.perf_counter()
    feasible_only = cfg.task.train_feasible_only
    fit_train, fit_val = (training_subset(s, feasible_only) for s in (train, val))
    fold_dir = Path(cfg.paths.output_dir) / f"fold_{fold.index}"
    module, fold_dir = fold_module(cfg, fit_train, fit_val, fold_dir, [progress])
    train_s = time.perf_counter() - tick
    progress.stage("evaluating")
    tick = time.perf_counter()
    ks = [int(k) for k in cfg.task.ks]
    policies = _policies(cfg, module, fold)
    metrics = {
        name: evaluate_by_size(scorer, test, ks, cfg.task.threshold, cfg.seed + fold.index)
        for name, scorer in policies.items()
    }
    estimator = OmegaConf.select(cfg, "classifier.estimator")
    if estimator is not None:
        classifiers = {cfg.classifier.name: instantiate(estimator)}
        add_schemes(metrics["GRACE"], embedding_schemes(module, train + val, test, classifiers))
    health = fold_health(metrics, fit_val, fold_dir / "logs", cfg.datamodule.states)
    if health["collapsed"]:
        log.warning("fold %d COLLAPSED: %s", fold.index, "; ".join(health["reasons"]))
    settings = RecordingSettings(**cfg.task.recording)
    records = []
    if settings.per_size > 0:  # sequences.rrd (docs/recordings.md)
        records = fold_views(
            policies["GRACE"], test, instantiate(cfg.simulator), settings.per_size,
            settings.top_k, settings.truth_orders, fold.index,
        )  # fmt: skip
    evaluate_s = time.perf_counter() - tick
    progress.done(train_s, evaluate_s)
    return FoldResult(metrics, train_s, evaluate_s, {"fold": fold.index, **health}, records)


def run(cfg: DictConfig) -> float:
    """Run the experiment of `cfg.protocol`; return the mean sequence AUC of GRACE."""
    start = time.perf_counter()
    out_dir = Path(cfg.paths.output_dir)
    data = instantiate(cfg.dataset).load()
    train_sizes, test_sizes, folds = protocol_folds(cfg, data)
    load_s = time.perf_counter() - start
    fold_results = run_folds(cfg, data, folds, run_fold)
    per_fold = {name: [r.metrics[name] for r in fold_results] for name in fold_results[0].metrics}
    per_size = aggregate(per_fold["GRACE"])
    baselines = {b: PolicyResults(aggregate(per_fold[b])) for b in cfg.task.baselines}
    health = TypeAdapter(list[FoldHealth]).validate_python([r.health for r in fold_results])
    results = ExperimentResults(
        protocol=cfg.protocol.name,
        train_sizes=train_sizes,
        test_sizes=test_sizes,
        folds=len(folds),
        per_size=per_size,
        baselines=baselines,
        seconds=time.perf_counter() - start,
        seconds_by_stage=StageSeconds(
            load_s, [r.train_s for r in fold_results], [r.evaluate_s for r in fold_results]
        ),
        collapsed_folds=[h.fold for h in health if h.collapsed],
        fold_health=health,
        run=RunInfo(
            model=OmegaConf.select(cfg, "model.name"),
            seed=cfg.seed,
            data_seed=OmegaConf.select(cfg, "dataset.seed"),  # None for raw data
            overrides=task_overrides(),
        ),
    )
    draw_side_files(write_side_files(per_fold["GRACE"], out_dir), out_dir)
    pr_curves({name: mean_curves(f) for name, f in per_fold.items()}, out_dir / "pr_curves.png")
    p_at_k_bars(results.policies(), out_dir / "p_at_k.png")
    records = [record for r in fold_results for record in r.records]
    if records:
        write_recording(records, out_dir / "sequences.rrd", out_dir.name)
    write_results(results, out_dir)  # last: a run folder with results.json is a finished run
    seq = [entry.seq_auc.mean for entry in per_size.values() if entry.seq_auc is not None]
    objective = float(np.mean(seq)) if seq else math.nan
    if results.collapsed_folds:
        log.warning("collapsed folds %s: see fold_health in results.json", results.collapsed_folds)
    log.info("mean sequence AUC %.4f, results in %s", objective, out_dir)
    return objective
