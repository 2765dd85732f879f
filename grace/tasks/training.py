"""One training run from the config: every part built with `hydra.utils.instantiate`.

`cfg.model` gives the GraceModule (network, encoding, implementation, optimiser and scheduler as
partials), `cfg.datamodule` the DataModule (a partial completed with the assemblies and the
model's encoding and collate function), `cfg.callbacks` and `cfg.logger` the named callbacks and
loggers, `cfg.trainer` the Lightning Trainer. grace.model.training.fit gets the objects.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import lightning.pytorch as pl
import numpy as np
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf, open_dict

from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.model.module import GraceModule
from grace.model.training import fit


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
    extra_states: Mapping[int, tuple[np.ndarray, np.ndarray]] | None = None,
) -> GraceModule:
    """A module trained on `train`, early-stopped on `val`, with its best checkpoint's weights.

    Checkpoints and logs go under `out_dir`; `callbacks` are added to the configured ones.
    `extra_states` adds (states, label masks) to `train[i]` by index (grace/tasks/dagger.py).
    """
    if not train:
        raise UserError(
            "the training set is empty; fix: check dataset.sizes and the protocol's sizes"
        )
    cfg = fit_config(cfg, out_dir, validated=bool(val))
    module = instantiate(cfg.model)
    datamodule = instantiate(cfg.datamodule)(
        train=train, val=val, enc=module.enc, collate=module.impl.collate
    )
    if extra_states:
        datamodule.train_set.extend(extra_states, datamodule.chunk_size)
    trainer = instantiate(
        cfg.trainer,
        callbacks=[*instantiate_named(cfg.callbacks), *callbacks],
        logger=instantiate_named(cfg.logger),
        **({} if val else {"limit_val_batches": 0}),
    )
    return fit(module, datamodule, trainer)
