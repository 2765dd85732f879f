"""Runs the task a composed config selects; shared set-up (seed, threads, logs) lives here once."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any, ClassVar

from hydra.core.hydra_config import HydraConfig
from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig

from grace.cli.checks import check_config, ignored_options
from grace.cli.determinism import cap_threads, seed_all
from grace.cli.logs import quiet_terminal
from grace.roles import WEIGHTS

log = logging.getLogger(__name__)


@dataclass
class TaskSettings:
    """What every `task` config holds (the base of each task's schema): its name, which names
    the run folder, and `run`, the task function as a `_partial_` target.

    `reads` (a class attribute, no config key) names the config groups with heavy schemas that
    the task reads (grace/cli/schemas.py, GROUP_SCHEMAS), None for all: the others compose
    untyped and their modules are not imported, which saves a task that trains nothing the
    seconds Lightning takes to load. A group the task does not read cannot change its results,
    so a kept run is compared without its keys (grace/cli/key_roles.py, run_roles)."""

    name: str = field(default=MISSING, metadata=WEIGHTS)
    run: Any = field(default=MISSING, metadata=WEIGHTS)
    reads: ClassVar[tuple[str, ...] | None] = None


def task_overrides() -> list[str]:
    """The command-line overrides of this run (none outside a Hydra run)."""
    return list(HydraConfig.get().overrides.task) if HydraConfig.initialized() else []


def run_task(cfg: DictConfig) -> float | None:
    """Check the config (grace/cli/checks.py), seed, cap the threads, run `cfg.task.run(cfg)`;
    its return value is the sweep objective."""
    quiet_terminal(cfg.paths.log_file)
    seed_all(cfg.seed)
    cap_threads(cfg.threads)
    log.info("task %s", cfg.task.name)
    for warning in ignored_options(cfg, task_overrides()):
        log.warning(warning)
    check_config(cfg)
    return instantiate(cfg.task.run)(cfg)
