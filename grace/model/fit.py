"""Training GRACE with Lightning (docs/training.md): fit, then keep the best checkpoint."""

from __future__ import annotations

import logging

import lightning.pytorch as pl

from grace.model.checkpoints import checkpoint_weights
from grace.model.module import GraceModule

log = logging.getLogger(__name__)


def fit(
    module: GraceModule,
    datamodule: pl.LightningDataModule,
    trainer: pl.Trainer,
    ckpt_path: str | None = None,
) -> GraceModule:
    """Train `module` on `datamodule` with `trainer`; return it with the best checkpoint's weights.

    The trainer's callbacks decide when to stop and what "best" is (early stopping and the first
    checkpoint callback with a monitor, both on the configured monitor). Without one, or before
    its first save, the module keeps its last weights. Returned in eval mode. `ckpt_path` resumes an
    interrupted fit from its last checkpoint (grace/model/resume.py).
    """
    # Our own file from the interrupted run: the full pickle (optimiser, generators) is trusted.
    trainer.fit(module, datamodule=datamodule, ckpt_path=ckpt_path, weights_only=False)
    monitored = [c for c in trainer.checkpoint_callbacks if getattr(c, "monitor", None)]
    checkpoint = monitored[0] if monitored else None
    best = getattr(checkpoint, "best_model_path", "")
    if best:
        log.info("best %s: %s (%s)", checkpoint.monitor, checkpoint.best_model_score, best)
        # Our own file from this run: the full pickle (hyper-parameters are objects) is trusted.
        module.load_state_dict(checkpoint_weights(best))
    return module.eval()
