"""`python -m grace task=feasibility`: the feasibility study alone (paper Sec. V-B.3, Fig. 5).

Per fold of the protocol: train GRACE on the training folds and, with `task.feasible_only`, a
second GRACE on their feasible assemblies only; then score every scheme of
grace/evaluation/feasibility_schemes.py on the fold's test assemblies: the planning schemes of both
models, the classifiers of `task.classifiers` on the first model's pooled embeddings, and the
densities of `task.densities` on each model's embeddings of feasible training assemblies.
Writes feasibility.json, feasibility_roc.png and results.md; returns the mean ROC AUC of the
best-sequence scheme over the test sizes.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig
from pydantic import TypeAdapter

from grace.cli.fit import fold_module
from grace.cli.folds import protocol_folds, run_folds, start_fold
from grace.cli.progress import FoldReporter
from grace.data.atomic import write_json_atomic, write_text_atomic
from grace.domain.sample import LabelledAssembly
from grace.evaluation.baselines import constant_scorer
from grace.evaluation.collapse import fold_health, state_step_auc
from grace.evaluation.feasibility_schemes import (
    add_schemes,
    embedding_schemes,
    feasibility_report,
    planning_schemes,
)
from grace.evaluation.protocols import Fold, training_subset
from grace.evaluation.report import feasibility_table, health_lines
from grace.evaluation.results import FoldHealth, SchemeSummary
from grace.planning.sequences import Scorer
from grace.roles import PLANNING, WEIGHTS
from grace.tasks.experiment import ExperimentSettings
from grace.visualisation.side_file_plots import feasibility_roc

log = logging.getLogger(__name__)


@dataclass
class FeasibilitySettings(ExperimentSettings):
    """Schema of `task=feasibility` (values in grace/conf/task/feasibility.yaml)."""

    feasible_only: bool = field(default=MISSING, metadata=WEIGHTS)
    """Also train a GRACE on the feasible assemblies only."""
    classifiers: Any = field(default=None, metadata=PLANNING)
    """Name → classifier config (the classifier group's `estimator`)."""
    densities: Any = field(default=None, metadata=PLANNING)
    """Name → density estimator config (grace/evaluation/density.py)."""


FEASIBLE_ONLY = "feasible-only GRACE, "
"""Prefix of the schemes read from the GRACE trained on feasible assemblies only."""


def _health(
    cfg: DictConfig,
    scorer: Scorer,
    test: list[LabelledAssembly],
    val: list[LabelledAssembly],
    log_dir: Path,
) -> dict:
    """fold_health from the on-path step AUC of the model and of the constant floor per size."""
    sizes = sorted({s.size for s in test})
    metrics = {
        name: {
            size: {"step_auc": state_step_auc(policy, [s for s in test if s.size == size])}
            for size in sizes
        }
        for name, policy in (("GRACE", scorer), ("constant", constant_scorer(0)))
    }
    return fold_health(metrics, val, log_dir, cfg.datamodule.states)


def run_fold(
    cfg: DictConfig,
    fold: Fold,
    train: list[LabelledAssembly],
    val: list[LabelledAssembly],
    test: list[LabelledAssembly],
    threads: int,
    progress: FoldReporter,
    parent: int,
) -> tuple[dict[int, dict], list[dict]]:
    """Every scheme's per-size summary on one fold, and the health of its models (arguments as
    grace.tasks.experiment.run_fold)."""
    start_fold(cfg, fold, threads, parent)
    make_scorer = instantiate(cfg.task.scorer)
    out = Path(cfg.paths.output_dir)
    runs = [("", train, val, out / f"fold_{fold.index}")]
    if cfg.task.feasible_only:
        runs.append(
            (
                FEASIBLE_ONLY,
                training_subset(train, feasible_only=True),
                training_subset(val, feasible_only=True),
                out / f"fold_{fold.index}_feasible_only",
            )
        )
    classifiers = {n: instantiate(c.estimator) for n, c in (cfg.task.classifiers or {}).items()}
    densities = {n: instantiate(d) for n, d in (cfg.task.densities or {}).items()}
    metrics: dict[int, dict] = {}
    health = []
    seconds = {"train": 0.0, "evaluate": 0.0}
    for prefix, fit_train, fit_val, fold_dir in runs:
        log.info("fold %d: training %sGRACE on %d assemblies", fold.index, prefix, len(fit_train))
        tick = time.perf_counter()
        module, fold_dir = fold_module(cfg, fit_train, fit_val, fold_dir, [progress])
        seconds["train"] += time.perf_counter() - tick
        progress.stage("evaluating")
        tick = time.perf_counter()
        scorer = make_scorer(module)
        add_schemes(metrics, planning_schemes(scorer, test, float(cfg.task.threshold)), prefix)
        schemes = embedding_schemes(module, fit_train + fit_val, test, classifiers, densities)
        add_schemes(metrics, schemes, prefix)
        state = _health(cfg, scorer, test, fit_val, fold_dir / "logs")
        if state["collapsed"]:
            log.warning("fold %d %sCOLLAPSED: %s", fold.index, prefix, "; ".join(state["reasons"]))
        health.append({"fold": fold.index, "model": prefix.rstrip(", ") or "GRACE", **state})
        seconds["evaluate"] += time.perf_counter() - tick
    progress.done(seconds["train"], seconds["evaluate"])
    return metrics, health


def run(cfg: DictConfig) -> float:
    """Run the feasibility study; return the mean best-sequence ROC AUC over test sizes."""
    out_dir = Path(cfg.paths.output_dir)
    data = instantiate(cfg.dataset).load()
    train_sizes, test_sizes, folds = protocol_folds(cfg, data)
    results = run_folds(cfg, data, folds, run_fold)
    report = feasibility_report([metrics for metrics, _ in results])
    report["health"] = [h for _, health in results for h in health]
    out_dir.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out_dir / "feasibility.json", report)
    feasibility_roc(report, out_dir / "feasibility_roc.png")
    sizes = list(report["per_size"])
    schemes = TypeAdapter(dict[str, dict[str, SchemeSummary]]).validate_python(report["per_size"])
    health = TypeAdapter(list[FoldHealth]).validate_python(report["health"])
    markdown = "\n\n".join(
        [
            f"# Feasibility: protocol {cfg.protocol.name}",
            f"Train sizes {train_sizes}, test sizes {test_sizes}, {len(folds)}-fold "
            "cross-validation; ROC AUC mean ± std over folds / TPR at FPR ≤ 0.05 (fold mean). "
            "Positive = feasible; schemes in grace/evaluation/feasibility_schemes.py.",
            feasibility_table(schemes, sizes),
            "## Folds",
            health_lines(health),
        ]
    )
    write_text_atomic(out_dir / "results.md", markdown + "\n")
    print(markdown)
    best = [
        e["best_sequence"]["roc_auc"]["mean"]
        for e in report["per_size"].values()
        if "best_sequence" in e
    ]
    return float(np.mean(best)) if best else math.nan
