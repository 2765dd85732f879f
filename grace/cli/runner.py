"""Runs the task a composed config selects; shared set-up (seed, threads, logs) lives here once."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import torch
from hydra.core.hydra_config import HydraConfig
from hydra.utils import instantiate
from lightning.pytorch import seed_everything
from omegaconf import MISSING, DictConfig

from grace.cli.checks import check_config, ignored_options
from grace.cli.logs import quiet_terminal

log = logging.getLogger(__name__)


@dataclass
class TaskSettings:
    """What every `task` config holds (the base of each task's schema): its name, which names
    the run folder, and `run`, the task function as a `_partial_` target."""

    name: str = MISSING
    run: Any = MISSING


def task_overrides() -> list[str]:
    """The command-line overrides of this run (none outside a Hydra run)."""
    return list(HydraConfig.get().overrides.task) if HydraConfig.initialized() else []


def run_task(cfg: DictConfig) -> float | None:
    """Check the config (grace/cli/checks.py), seed, cap the threads, run `cfg.task.run(cfg)`;
    its return value is the sweep objective."""
    quiet_terminal(cfg.paths.log_file)
    seed_everything(cfg.seed, workers=True, verbose=False)
    torch.set_num_threads(cfg.threads)
    log.info("task %s", cfg.task.name)
    for warning in ignored_options(cfg, task_overrides()):
        log.warning(warning)
    check_config(cfg)
    return instantiate(cfg.task.run)(cfg)
