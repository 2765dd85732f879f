"""`python -m grace task=tune`: an Optuna search over any config keys (docs/tuning.md).

The `tune` group holds the study (name, storage, sampler, pruner, metric) and its space
(grace/cli/tune_space.py). A trial sets the space's keys in the composed config and trains the
protocol's first `tune.folds` folds one after another; its value is the mean over those folds of
`tune.metric` on the fold's validation assemblies at the epoch whose weights the fold keeps (the
best checkpoint on `monitor`). Test assemblies are never scored. The first fold reports the
metric after every epoch to the pruner (optuna-integration's Lightning callback), so a bad trial
stops early; later folds are not pruned: the first fold is the same split in every trial, so its
epochs compare like with like, and a trial that survives it is trained on all its folds.

Optuna's own `study.optimize` runs the trials (a storage URL, several processes on one study);
the study is created or continued under `tune.study_name`.
"""

from __future__ import annotations

import logging
import math
import random
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import lightning.pytorch as pl
import numpy as np
import optuna
import sqlalchemy.exc
from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig, OmegaConf
from optuna_integration import PyTorchLightningPruningCallback

from grace.cli.determinism import seed_all
from grace.cli.folds import protocol_folds
from grace.cli.runner import TaskSettings, task_overrides
from grace.cli.tune_space import Param, parse_space, suggest, trial_config
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.roles import WEIGHTS
from grace.tasks.tune.tune_report import write_report

log = logging.getLogger(__name__)


@dataclass
class TuneSettings(TaskSettings):
    """Schema of `task=tune` (values in grace/conf/task/tune.yaml; the study in `tune`)."""

    # (cfg, train, val, out_dir, callbacks) -> trained module, a partial
    fit: Any = field(default=MISSING, metadata=WEIGHTS)
    # the generated data set's seed: the selection data set
    data_seed: int = field(default=MISSING, metadata=WEIGHTS)


class KeptMetric(pl.Callback):
    """Records `metric` and the monitored metric after every validation epoch, so the metric of
    the epoch whose weights the best checkpoint keeps can be read after training."""

    def __init__(self, metric: str, monitor: str, mode: str) -> None:
        self.metric, self.monitor, self.mode = metric, monitor, mode
        self.epochs: list[tuple[float, float]] = []

    def on_validation_end(self, trainer: pl.Trainer, pl_module: pl.LightningModule) -> None:
        metrics = trainer.callback_metrics
        if not trainer.sanity_checking and self.metric in metrics and self.monitor in metrics:
            self.epochs.append((float(metrics[self.metric]), float(metrics[self.monitor])))

    def kept(self) -> float:
        """`metric` at the first epoch with the best monitored value (the checkpoint saves on
        strict improvement only, so ties keep the earliest)."""
        if not self.epochs:
            raise UserError(
                f"tune.metric={self.metric}: not logged on validation assemblies; "
                "fix: use val_step_auc or val_loss, and a protocol with validation assemblies"
            )
        monitored = np.array([m for _, m in self.epochs])
        best = int(np.argmin(monitored) if self.mode == "min" else np.argmax(monitored))
        return self.epochs[best][0]


class _Data:
    """The data set of a trial's config, loaded once per distinct `dataset` config."""

    def __init__(self) -> None:
        self._cache: dict[str, list[LabelledAssembly]] = {}

    def __call__(self, cfg: DictConfig) -> list[LabelledAssembly]:
        key = OmegaConf.to_yaml(cfg.dataset, resolve=True)
        if key not in self._cache:
            self._cache[key] = instantiate(cfg.dataset).load()
        return self._cache[key]


def _objective(cfg: DictConfig, params: list[Param], out_dir: Path, prune: bool) -> Any:
    data_for = _Data()
    metric = cfg.tune.metric

    def objective(trial: optuna.Trial) -> float:
        values = suggest(trial, params)
        trial_cfg = trial_config(cfg, values)
        data = data_for(trial_cfg)
        folds = protocol_folds(trial_cfg, data)[2][: cfg.tune.folds]
        scores = []
        for position, fold in enumerate(folds):
            kept = KeptMetric(metric, trial_cfg.monitor.metric, trial_cfg.monitor.mode)
            callbacks: list[pl.Callback] = [kept]
            if prune and position == 0:
                callbacks.append(PyTorchLightningPruningCallback(trial, monitor=metric))
            seed_all(int(trial_cfg.seed) + fold.index)
            instantiate(trial_cfg.task.fit)(
                trial_cfg,
                [data[i] for i in fold.train],
                [data[i] for i in fold.val],
                out_dir / f"trial_{trial.number}" / f"fold_{fold.index}",
                callbacks=callbacks,
            )
            scores.append(kept.kept())
            trial.set_user_attr(f"fold_{fold.index}", scores[-1])
        return float(np.mean(scores))

    return objective


def storage_url(cfg: DictConfig, out_dir: Path) -> str:
    """`tune.storage`, or by default an SQLite file in the run folder."""
    return cfg.tune.storage or f"sqlite:///{(out_dir / 'study.db').absolute()}"


STORAGE_ATTEMPTS = 10
"""Tries at opening a storage that other processes may be creating at the same moment."""


def rdb_storage(url: str) -> optuna.storages.RDBStorage:
    """The database at `url`, its tables created if missing. Processes started together on a
    new database each create the tables and stamp their version, and all but one fail (a table
    or version row that another just made); the tables are there once one has succeeded, so
    the others try again after a short random wait."""
    for attempt in range(1, STORAGE_ATTEMPTS):
        try:
            return optuna.storages.RDBStorage(url)
        except sqlalchemy.exc.SQLAlchemyError:
            time.sleep(random.uniform(0.05, 0.2) * attempt)
    return optuna.storages.RDBStorage(url)  # the last try raises what fails


def open_study(cfg: DictConfig, storage: str) -> optuna.Study:
    """The study `tune.study_name` in `storage`, created or continued, with the configured
    pruner and a sampler seeded by `sampler.seed` plus the number of trials already in the
    study: a continued study draws new points rather than repeating the first process's."""
    tune = cfg.tune
    pruner = instantiate(tune.pruner) if tune.pruner is not None else optuna.pruners.NopPruner()
    study = optuna.create_study(  # a study another process just created is loaded
        storage=rdb_storage(storage),
        study_name=tune.study_name,
        direction=str(tune.direction),
        pruner=pruner,
        load_if_exists=True,
    )
    if study.direction.name.lower() != str(tune.direction):
        raise UserError(
            f"tune.direction={tune.direction}: study {tune.study_name} in {storage} was created "
            f"to {study.direction.name.lower()}; fix: use that direction or a new tune.study_name"
        )
    seed = OmegaConf.select(tune.sampler, "seed")
    extra = {} if seed is None else {"seed": int(seed) + len(study.trials)}
    study.sampler = instantiate(tune.sampler, **extra)
    return study


def run(cfg: DictConfig) -> float:
    """Run `tune.n_trials` trials in the study; write the report; return the best value."""
    out_dir = Path(cfg.paths.output_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cfg = trial_config(cfg, {"trainer.enable_progress_bar": False})  # one line per trial instead
    params = parse_space(cfg.tune.space, cfg)
    storage = storage_url(cfg, out_dir)
    study = open_study(cfg, storage)
    log.info(
        "study %s: %d trials so far; follow it with: optuna-dashboard %s",
        *(cfg.tune.study_name, len(study.trials), storage),
    )
    objective = _objective(cfg, params, out_dir, prune=cfg.tune.pruner is not None)
    study.optimize(objective, n_trials=cfg.tune.n_trials, timeout=cfg.tune.timeout)
    report = write_report(study, cfg, out_dir, storage, task_overrides())
    log.info("%s", report.message)
    return report.best_value if report.best_value is not None else math.nan
