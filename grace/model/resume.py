"""Exact resumption of a killed training run from Lightning's `last.ckpt`.

Lightning's checkpoint restores the weights, optimiser, lr scheduler, loop counters and the
callbacks' states (early stopping, best checkpoint), and the DataModule restores its shuffling
(grace/graphs/datamodule.py). The global random generators it does not keep: this callback adds
them, so anything drawn from them during training (dropout, sampling) continues as in an
uninterrupted run. `last.ckpt` is written after every epoch (`callbacks.last_checkpoint`), so a
resumed fit goes on with the epoch after the last finished one and ends with the weights of an
uninterrupted fit.
"""

from __future__ import annotations

import random
from typing import Any

import lightning.pytorch as pl
import numpy as np
import torch

KEY = "grace_resume"
"""Where in the checkpoint dictionary this callback keeps its state."""


class ResumeState(pl.Callback):
    """Saves the global random generators in every checkpoint; restores them when a fit
    resumes from one."""

    def on_save_checkpoint(
        self, trainer: pl.Trainer, pl_module: pl.LightningModule, checkpoint: dict[str, Any]
    ) -> None:
        checkpoint[KEY] = {
            "torch": torch.get_rng_state(),
            "numpy": np.random.get_state(),
            "python": random.getstate(),
        }

    def on_load_checkpoint(
        self, trainer: pl.Trainer, pl_module: pl.LightningModule, checkpoint: dict[str, Any]
    ) -> None:
        state = checkpoint.get(KEY)
        if state is not None:
            torch.set_rng_state(state["torch"])
            np.random.set_state(state["numpy"])
            random.setstate(state["python"])
