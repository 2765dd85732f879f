"""Runs the task a composed config selects; shared set-up (seed, threads) lives here once."""

from __future__ import annotations

import logging

import torch
from hydra.utils import get_method
from lightning.pytorch import seed_everything
from omegaconf import DictConfig

log = logging.getLogger(__name__)


def run_task(cfg: DictConfig) -> float | None:
    """Seed, cap the threads, call `cfg.task.fn(cfg)`; its return value is the sweep objective."""
    seed_everything(cfg.seed, workers=True, verbose=False)
    torch.set_num_threads(cfg.threads)
    log.info("task %s", cfg.task.name)
    return get_method(cfg.task.fn)(cfg)
