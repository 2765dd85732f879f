"""Exact resumption of a killed training run from `last.ckpt` (docs/operations.md, "Resume").

Lightning's ModelCheckpoint writes its checkpoint inside the epoch's end, before the
epoch-interval lr schedulers step (a plateau scheduler counts its bad epochs and may lower the
lr), and a fit resumed from it finishes that epoch's end without the step (Lightning skips it on
purpose: a plateau scheduler's metric is not in the checkpoint). The resumed fit then lags one
scheduler update behind and diverges once the plateau decides, `patience` epochs later. So
:class:`LastCheckpoint` writes `last.ckpt` at the true end of an epoch instead, when every
end-of-epoch update (callbacks, loggers, lr schedulers, loop counters, the data module's
shuffling) has run: as the next epoch starts, before it draws anything, and when the fit ends.
The loggers are flushed first, so the logged history reaches the disk with it. A fit resumed
from it starts the next epoch as an uninterrupted one would. The checkpoint also holds the global
random generators (Lightning does not keep them), so anything drawn from them during training
(dropout, sampling) continues as in an uninterrupted run, and whether the fit had ended (early
stopping), so a rerun after the end trains no further epoch.
"""

from __future__ import annotations

import os
import random
from pathlib import Path
from typing import Any

import lightning.pytorch as pl
import numpy as np
import torch

KEY = "grace_resume"
"""Where in the checkpoint dictionary :class:`LastCheckpoint` keeps its state."""

LAST_NAME = "last.ckpt"


def _generators() -> dict[str, Any]:
    return {
        "torch": torch.get_rng_state(),
        "numpy": np.random.get_state(),
        "python": random.getstate(),
    }


def _set_generators(state: dict[str, Any]) -> None:
    torch.set_rng_state(state["torch"])
    np.random.set_state(state["numpy"])
    random.setstate(state["python"])


class LastCheckpoint(pl.Callback):
    """Writes `<dirpath>/last.ckpt` (atomically) after each epoch's last update; restores the
    global random generators and the fit's end when a fit resumes from it."""

    def __init__(self, dirpath: str) -> None:
        self.dirpath = dirpath
        self._epoch_ended = False
        self._finished = False
        self._resumed = False
        self._resumed_finished = False

    @property
    def path(self) -> Path:
        return Path(self.dirpath) / LAST_NAME

    def _save(self, trainer: pl.Trainer) -> None:
        # The logs up to this epoch reach the disk with the checkpoint: a resumed fit continues
        # them (grace/evaluation/collapse.py reads the history of every run of a fit).
        for logger in trainer.loggers:
            logger.save()
        # Lightning writes the file in place; a kill in the middle would leave half a checkpoint.
        tmp = self.path.with_name(f".{LAST_NAME}.{os.getpid()}.tmp")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            trainer.save_checkpoint(tmp)
            os.replace(tmp, self.path)
        finally:
            tmp.unlink(missing_ok=True)
        self._epoch_ended = False

    def on_train_epoch_end(self, trainer: pl.Trainer, pl_module: pl.LightningModule) -> None:
        self._epoch_ended = True

    def on_train_epoch_start(self, trainer: pl.Trainer, pl_module: pl.LightningModule) -> None:
        if self._epoch_ended:
            self._save(trainer)

    def on_train_start(self, trainer: pl.Trainer, pl_module: pl.LightningModule) -> None:
        if not self._resumed:
            return
        # Lightning treats a restored fit's first epoch as the tail of an interrupted one: it
        # would skip that epoch's lr-scheduler step and, restored at an epoch boundary, run no
        # batch at all. Ours is restored at a boundary, with every update of the epoch before
        # done: the loops go on as after any finished epoch.
        loop = trainer.fit_loop
        loop.restarting = False
        loop.epoch_loop.reset_restart_stage()
        loop.epoch_loop.val_loop.reset_restart_stage()
        if self._resumed_finished:
            trainer.should_stop = True

    def on_train_end(self, trainer: pl.Trainer, pl_module: pl.LightningModule) -> None:
        if self._epoch_ended:
            self._finished = True
            self._save(trainer)

    def on_save_checkpoint(
        self, trainer: pl.Trainer, pl_module: pl.LightningModule, checkpoint: dict[str, Any]
    ) -> None:
        checkpoint[KEY] = {"generators": _generators(), "finished": self._finished}

    def on_load_checkpoint(
        self, trainer: pl.Trainer, pl_module: pl.LightningModule, checkpoint: dict[str, Any]
    ) -> None:
        state = checkpoint.get(KEY)
        if state is not None:
            _set_generators(state["generators"])
            self._resumed = True
            self._resumed_finished = bool(state["finished"])
