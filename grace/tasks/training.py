"""One training run from the config: every part built with `hydra.utils.instantiate`.

`cfg.model` gives the GraceModule (network, encoding, implementation, optimiser and scheduler as
partials), `cfg.datamodule` the DataModule (a partial completed with the assemblies and the
model's encoding and collate function), `cfg.callbacks` and `cfg.logger` the named callbacks and
loggers, `cfg.trainer` the Lightning Trainer. grace.model.training.fit gets the objects.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import lightning.pytorch as pl
from hydra.utils import instantiate
from lightning.pytorch.callbacks import ModelCheckpoint
from omegaconf import DictConfig, OmegaConf, open_dict

from grace.data.atomic import write_text_atomic
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.model.module import GraceModule
from grace.model.training import fit

KEPT_CONFIG = "config.yaml"
"""The resolved config of a training run, kept in its folder beside `checkpoints/` so that the
model can be rebuilt later (task=plan)."""


def keep_config(cfg: DictConfig, out_dir: str | Path) -> Path:
    """Write `cfg` (resolved, without Hydra's own node) to `out_dir/config.yaml`."""
    node = OmegaConf.to_container(cfg, resolve=True)
    node.pop("hydra", None)
    path = Path(out_dir) / KEPT_CONFIG
    write_text_atomic(path, OmegaConf.to_yaml(OmegaConf.create(node)))
    return path


def fit_config(cfg: DictConfig, out_dir: str | Path, validated: bool) -> DictConfig:
    """A copy of `cfg` for one training run that writes into `out_dir`.

    Without validation assemblies the monitor (early stopping, best checkpoint, lr scheduler)
    becomes the training loss.
    """
    cfg = OmegaConf.create(OmegaConf.to_container(cfg, resolve=False))
    with open_dict(cfg):
        cfg.paths.fit_dir = str(out_dir)
        if not validated:
            cfg.monitor = {"metric": "train_loss", "mode": "min"}
    return cfg


def instantiate_named(group: DictConfig | None) -> list:
    """The objects of a group of named configs (`callbacks`, `logger`); null entries skipped."""
    return [instantiate(node) for node in (group or {}).values() if node is not None]


def train_module(
    cfg: DictConfig,
    train: Sequence[LabelledAssembly],
    val: Sequence[LabelledAssembly],
    out_dir: str | Path,
    callbacks: Sequence[pl.Callback] = (),
) -> GraceModule:
    """A module trained on `train`, early-stopped on `val`, with its best checkpoint's weights.

    Checkpoints, logs and the run's config (config.yaml) go under `out_dir`; `callbacks` are
    added to the configured ones.
    """
    if not train:
        raise UserError(
            "the training set is empty; fix: check dataset.sizes and the protocol's sizes"
        )
    cfg = fit_config(cfg, out_dir, validated=bool(val))
    keep_config(cfg, out_dir)
    module = instantiate(cfg.model)
    datamodule = instantiate(cfg.datamodule)(
        train=train, val=val, enc=module.enc, collate=module.impl.collate
    )
    configured = instantiate_named(cfg.callbacks)
    trainer = instantiate(
        cfg.trainer,
        callbacks=[*configured, *callbacks],
        logger=instantiate_named(cfg.logger),
        **({} if val else {"limit_val_batches": 0}),
    )
    return fit(module, datamodule, trainer, ckpt_path=resume_from(cfg, out_dir, configured))


RUN_ONLY = (
    *("paths", "threads", "debug", "task.fold_jobs", "trainer.enable_progress_bar"),
    *("dataset.workers", "dataset.data_dir"),
)
"""Keys that change where or how fast a run goes, never its results: a rerun may change them."""


def resume_from(cfg: DictConfig, out_dir: str | Path, callbacks: Sequence[object]) -> str | None:
    """The `last.ckpt` that a killed run of this config left in `out_dir`, or None (then this
    run's config is recorded in `out_dir/fit_config.yaml`, to recognise it on a rerun).

    A last checkpoint written under another config is a UserError: resuming it would mix two
    experiments.
    """
    saving = [c for c in callbacks if isinstance(c, ModelCheckpoint) and c.save_last]
    if not saving or saving[0].dirpath is None:
        return None
    checkpoint = saving[0]
    last = (
        Path(checkpoint.dirpath) / f"{checkpoint.CHECKPOINT_NAME_LAST}{checkpoint.FILE_EXTENSION}"
    )
    kept = OmegaConf.to_container(cfg, resolve=True)
    for key in RUN_ONLY:
        *parents, name = key.split(".")
        node = kept
        for parent in parents:
            node = node.get(parent) or {}
        node.pop(name, None)
    text = OmegaConf.to_yaml(OmegaConf.create(kept))
    record = Path(out_dir) / "fit_config.yaml"
    if not last.exists():
        write_text_atomic(record, text)
        return None
    if record.exists() and record.read_text() != text:
        raise UserError(
            f"{last} was written by a run of another config ({record}); fix: the same "
            f"overrides as that run, or a new paths.output_dir, or delete {Path(out_dir)}"
        )
    return str(last)
