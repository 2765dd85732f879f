"""One training run from the config: every part built with `hydra.utils.instantiate`.

`cfg.model` gives the GraceModule (network, encoding, implementation, optimiser and scheduler as
partials), `cfg.datamodule` the DataModule (a partial completed with the assemblies and the
model's encoding and collate function), `cfg.callbacks` and `cfg.logger` the named callbacks and
loggers, `cfg.trainer` the Lightning Trainer. grace.model.fit.fit gets the objects.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import lightning.pytorch as pl
import numpy as np
import torch
from hydra.errors import InstantiationException
from hydra.utils import instantiate
from lightning.fabric.utilities.exceptions import MisconfigurationException
from omegaconf import DictConfig, OmegaConf, open_dict

from grace.cli.key_roles import keys_of
from grace.data.atomic import write_text_atomic
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.model.checkpoints import checkpoint_weights
from grace.model.fit import fit
from grace.model.kept import CHECKPOINT, KEPT_CONFIG, read_kept_config
from grace.model.module import GraceModule
from grace.model.resume import LastCheckpoint
from grace.roles import Role


def _resolved(cfg: DictConfig) -> dict:
    """`cfg` resolved, without Hydra's own node: what config.yaml holds."""
    node = OmegaConf.to_container(cfg, resolve=True)
    node.pop("hydra", None)
    return node


def keep_config(cfg: DictConfig, out_dir: str | Path) -> Path:
    """Write `cfg` (resolved, without Hydra's own node) to `out_dir/config.yaml`: task=plan
    rebuilds the model from it, and a rerun compares itself with it before resuming."""
    path = Path(out_dir) / KEPT_CONFIG
    write_text_atomic(path, OmegaConf.to_yaml(OmegaConf.create(_resolved(cfg))))
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
    extra_states: Mapping[int, tuple[np.ndarray, np.ndarray]] | None = None,
) -> GraceModule:
    """A module trained on `train`, early-stopped on `val`, with its best checkpoint's weights.

    Checkpoints, logs and the run's config (config.yaml) go under `out_dir`; `callbacks` are
    added to the configured ones. `extra_states` adds (states, label masks) to `train[i]` by
    index (grace/cli/dagger_fit.py).
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
    configured = instantiate_named(cfg.callbacks)
    trainer = _trainer(
        cfg,
        callbacks=[*configured, *callbacks],
        logger=instantiate_named(cfg.logger),
        **({} if val else {"limit_val_batches": 0}),
    )
    resume = resume_from(cfg, out_dir, configured)
    keep_config(cfg, out_dir)
    return fit(module, datamodule, trainer, ckpt_path=resume)


def _trainer(cfg: DictConfig, **kwargs: object) -> pl.Trainer:
    """The configured Trainer; an accelerator this machine lacks (`trainer=gpu` where torch sees
    no CUDA device) is one line with the fix, before anything is written."""
    try:
        return instantiate(cfg.trainer, **kwargs)
    except InstantiationException as error:
        if not isinstance(error.__cause__, MisconfigurationException):
            raise
        raise UserError(
            f"trainer.accelerator={cfg.trainer.accelerator}: {error.__cause__}, torch "
            f"{torch.__version__} sees no such device; fix: trainer=cpu, or a CUDA build of "
            "torch on a machine with a GPU"
        ) from None


def _ignored(cfg: DictConfig, *roles: Role) -> tuple[str, ...]:
    """The keys of `cfg`'s task and groups whose declared role (grace/roles.py) is one of
    `roles`: they may differ between a kept run and this one."""
    return keys_of(OmegaConf.select(cfg, "task.run._target_", default=None), *roles)


def _results_keys(node: dict, ignored: Sequence[str]) -> dict:
    """`node` without the `ignored` keys."""
    node = OmegaConf.to_container(OmegaConf.create(node))
    for key in ignored:
        *parents, name = key.split(".")
        inner = node
        for parent in parents:
            inner = inner.get(parent) or {}
        inner.pop(name, None)
    return node


def _last_checkpoint(callbacks: Sequence[object]) -> Path | None:
    """Where the configured callbacks write the checkpoint a rerun resumes from, or None: our
    `last_checkpoint` (grace/model/resume.py), the only one written after the epoch's lr
    scheduler steps."""
    found = [c.path for c in callbacks if isinstance(c, LastCheckpoint)]
    return found[0] if found else None


def resume_from(cfg: DictConfig, out_dir: str | Path, callbacks: Sequence[object]) -> str | None:
    """The `last.ckpt` that a killed run of this config left in `out_dir`, or None.

    Called before keep_config overwrites `out_dir/config.yaml`: a last checkpoint whose run kept
    another config is a UserError, since resuming it would mix two experiments. Keys declared
    `run` (where or how fast a run goes: paths, threads, workers) may differ.
    """
    last = _last_checkpoint(callbacks)
    if last is None or not last.exists():
        return None
    record = Path(out_dir) / KEPT_CONFIG
    before = OmegaConf.to_container(read_kept_config(record, ())) if record.exists() else None
    ignored = _ignored(cfg, Role.run)
    if before is not None and _results_keys(before, ignored) != _results_keys(
        _resolved(cfg), ignored
    ):
        raise UserError(
            f"{last} was written by a run of another config ({record}); fix: the same "
            f"overrides as that run, or a new paths.output_dir, or delete {Path(out_dir)}"
        )
    return str(last)


def _flat(node: object, prefix: str = "") -> dict[str, object]:
    if not isinstance(node, dict):
        return {prefix: node}
    out: dict[str, object] = {}
    for key, value in node.items():
        out |= _flat(value, f"{prefix}.{key}" if prefix else str(key))
    return out


OFF = (None, False, 0, "", [], {})
"""Values of a key that a kept run's config lacks under which it still compares equal: options
are added switched off (e.g. `model.net.extra_part_features: 0`), as the older run was."""


def kept_module(cfg: DictConfig, fold_dir: str | Path, validated: bool = True) -> GraceModule:
    """The module a run kept in `fold_dir` (its best checkpoint), built from `cfg.model`, so
    that keys declared `planning` or `run` (e.g. `model.net.score`, grace/roles.py) may differ
    from the run's. The run's kept config must equal `cfg` in every key that decides the
    weights (a key newer than the run counts as equal while it is off, OFF): a checkpoint of
    another data set, protocol, model or schedule is a UserError naming the first keys that
    differ.
    `validated`: whether the fold had validation assemblies (it decides the monitor)."""
    fold_dir = Path(fold_dir)
    ckpt, kept = fold_dir / CHECKPOINT, fold_dir / KEPT_CONFIG
    if not ckpt.is_file() or not kept.is_file():
        raise UserError(
            f"task.checkpoints: no {CHECKPOINT} and {KEPT_CONFIG} in {fold_dir}; fix: the folder "
            "of an experiment run of this protocol whose folds finished training"
        )
    ignored = _ignored(cfg, Role.run, Role.planning)
    before = _flat(_results_keys(OmegaConf.to_container(read_kept_config(kept, ())), ignored))
    now = _flat(_results_keys(_resolved(fit_config(cfg, fold_dir, validated)), ignored))
    differ = sorted(k for k in before.keys() | now.keys() if before.get(k) != now.get(k))
    differ = [k for k in differ if k in before or now[k] not in OFF]
    if differ:
        shown = ", ".join(f"{k} (kept {before.get(k)!r}, now {now.get(k)!r})" for k in differ[:3])
        raise UserError(
            f"task.checkpoints: {kept} was trained with another config: {shown}; fix: the same "
            "overrides as that run, changing only keys that do not train (e.g. model.net.score)"
        )
    module = instantiate(cfg.model)
    module.load_state_dict(checkpoint_weights(ckpt), strict=True)
    return module.eval()


def fold_module(
    cfg: DictConfig,
    train: Sequence[LabelledAssembly],
    val: Sequence[LabelledAssembly],
    fold_dir: Path,
    callbacks: Sequence[pl.Callback] = (),
) -> tuple[GraceModule, Path]:
    """A fold's model and the folder of its logs: trained by `task.fit` into `fold_dir`, or
    with `task.checkpoints` the one that run kept in its folder of the same name (kept_module),
    so that every cross-validated task re-plans kept folds the same way."""
    if cfg.task.checkpoints is None:
        return instantiate(cfg.task.fit)(
            cfg, train, val, fold_dir, callbacks=list(callbacks)
        ), fold_dir
    kept = Path(cfg.task.checkpoints) / fold_dir.name
    return kept_module(cfg, kept, validated=bool(val)), kept
