"""The folds of a cross-validated task, run side by side: from the composed config to the
per-fold results of a fold function, with one progress display (grace/cli/progress.py).

`task=experiment`, `task=feasibility` and `task=tune` split the data set by `protocol`
(docs/protocols.md); the first two run a fold function on every fold, `task.fold_jobs` at a time
in separate processes (joblib), each seeded by `seed + fold index`.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from joblib import Parallel, delayed
from omegaconf import DictConfig, OmegaConf
from tqdm.contrib.logging import logging_redirect_tqdm

from grace.cli.checks import protocol_split
from grace.cli.determinism import cap_threads, seed_all
from grace.cli.logs import log_to_file
from grace.cli.progress import ExperimentProgress
from grace.cli.signals import as_worker
from grace.domain.canonical import copy_groups
from grace.domain.sample import LabelledAssembly
from grace.evaluation.protocols import Fold, make_folds

log = logging.getLogger(__name__)


def protocol_folds(
    cfg: DictConfig, data: list[LabelledAssembly]
) -> tuple[list[int], list[int], list[Fold]]:
    """(train sizes, test sizes, folds) of `cfg.protocol` over `data`, every group of copies
    (the same assembly up to part numbering, grace/domain/canonical.py) kept in one fold."""
    proto = cfg.protocol
    sizes = [sample.size for sample in data]
    train_sizes, test_sizes = protocol_split(proto, sizes)
    groups = copy_groups(data)
    copies = len(groups) - len(np.unique(groups))
    if copies:
        log.info("%d assemblies are copies of others: each kept in its original's fold", copies)
    folds = make_folds(
        sizes, train_sizes, test_sizes, proto.folds, proto.val_fraction, proto.seed, groups
    )
    return train_sizes, test_sizes, folds


def start_fold(cfg: DictConfig, fold: Fold, threads: int, parent: int) -> None:
    """What every fold does first, in whichever process runs it: seed by `seed + fold index`
    (so a fold's result does not depend on which folds ran before it or where), cap the threads,
    and in a worker process (not `parent`) take a worker's signals (grace/cli/signals.py) and
    send all messages to the run's log file."""
    if os.getpid() != parent:
        as_worker()
        log_to_file(cfg.paths.log_file, f"fold {fold.index}")
    seed_all(int(cfg.seed) + fold.index)
    cap_threads(threads)


def portable(cfg: DictConfig) -> DictConfig:
    """A copy of `cfg` that worker processes can use: they have no Hydra runtime, so the one key
    that reads it (`paths.output_dir`) is resolved; the other interpolations stay live."""
    out = OmegaConf.create(OmegaConf.to_container(cfg, resolve=False))
    out.paths.output_dir = str(Path(cfg.paths.output_dir).absolute())
    if "trainer" in out:  # the task shows each fold's progress itself (progress.py)
        out.trainer.enable_progress_bar = False
    return out


def run_folds(
    cfg: DictConfig,
    data: list[LabelledAssembly],
    folds: list[Fold],
    fold_fn: Callable[..., Any],
) -> list:
    """`fold_fn(cfg, fold, train, val, test, threads, reporter, parent pid)` on all folds,
    `task.fold_jobs` at a time in separate processes (joblib), threads split."""
    jobs = max(1, min(int(cfg.task.fold_jobs), len(folds)))
    threads = max(1, int(cfg.threads) // jobs)
    cfg = portable(cfg)
    with ExperimentProgress(len(folds)) as progress, logging_redirect_tqdm():
        tasks = (
            delayed(fold_fn)(
                cfg,
                fold,
                [data[i] for i in fold.train],
                [data[i] for i in fold.val],
                [data[i] for i in fold.test],
                threads,
                progress.reporter(fold.index),
                os.getpid(),
            )
            for fold in folds
        )
        # Processes, never threads: folds seed the global RNGs, which threads would share.
        return list(Parallel(n_jobs=jobs, backend="loky")(tasks))
