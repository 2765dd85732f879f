"""Training GRACE with Lightning (SPEC §5): Adam, early stopping, checkpoints, CSV logger."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import lightning.pytorch as pl
from lightning.pytorch.callbacks import EarlyStopping, ModelCheckpoint
from lightning.pytorch.loggers import CSVLogger, TensorBoardLogger
from omegaconf import DictConfig, OmegaConf

from grace.domain.sample import LabelledAssembly
from grace.graphs.datamodule import StateDataModule
from grace.model.module import GraceModule

log = logging.getLogger(__name__)

LOGGERS = ("csv", "tensorboard")


def make_module(cfg: DictConfig) -> GraceModule:
    """A fresh GraceModule from `cfg.model`, `cfg.trainer` (lr, lr_decay) and `cfg.seed`."""
    model: dict[str, Any] = OmegaConf.to_container(cfg.model, resolve=True)  # type: ignore[assignment]
    decay = cfg.trainer.get("lr_decay")
    decay = OmegaConf.to_container(decay, resolve=True) if decay is not None else None
    return GraceModule(model, lr=float(cfg.trainer.lr), seed=int(cfg.seed), lr_decay=decay)


def _logger(kind: str, out_dir: Path) -> CSVLogger | TensorBoardLogger:
    if kind == "csv":
        return CSVLogger(out_dir, name="logs")
    if kind == "tensorboard":
        return TensorBoardLogger(out_dir, name="logs")
    raise ValueError(f"trainer.logger={kind!r}: use one of {LOGGERS}")


def fit(
    cfg: DictConfig,
    train: list[LabelledAssembly],
    val: list[LabelledAssembly],
    out_dir: Path,
) -> GraceModule:
    """Train on `train`, early-stop on `val`, return the module with the best checkpoint's weights.

    Checkpoints and logs go under `out_dir`. With an empty `val` the training loss is monitored.
    """
    if not train:
        raise ValueError("fit: the training set is empty (check the data set and protocol sizes)")
    out_dir = Path(out_dir)
    t = cfg.trainer
    module = make_module(cfg)
    data = StateDataModule(
        train,
        val,
        module.enc,
        impl=module.impl,
        states=t.datamodule.states,
        batch_size=int(t.batch_size),
        seed=int(cfg.seed),
        mixing=t.datamodule.get("mixing", "assembly"),
    )
    monitor, mode = (t.monitor, t.monitor_mode) if val else ("train_loss", "min")
    module.monitor, module.monitor_mode = monitor, mode
    checkpoint = ModelCheckpoint(
        dirpath=out_dir / "checkpoints", filename="best", monitor=monitor, mode=mode, save_top_k=1
    )
    trainer = pl.Trainer(
        accelerator="cpu",
        devices=1,
        max_epochs=int(t.max_epochs),
        max_time=t.max_time,
        gradient_clip_val=t.get("gradient_clip"),
        logger=_logger(t.logger, out_dir),
        callbacks=[EarlyStopping(monitor=monitor, mode=mode, patience=int(t.patience)), checkpoint],
        enable_progress_bar=bool(t.progress_bar),
        enable_model_summary=False,
        log_every_n_steps=1,
        num_sanity_val_steps=0,
        limit_val_batches=1.0 if val else 0,
    )
    trainer.fit(module, datamodule=data)
    if checkpoint.best_model_path:
        log.info("best %s: %s", monitor, checkpoint.best_model_score)
        module = GraceModule.load_from_checkpoint(checkpoint.best_model_path)
    return module.eval()
