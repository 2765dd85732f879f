"""Checkpoints this project writes, and the models rebuilt from them (task=plan).

A training run keeps its resolved config (`config.yaml`, KEPT_CONFIG) in its folder beside
`checkpoints/` (grace/cli/fit.py), so a model is rebuilt from that config and the checkpoint's
weights must fit it exactly: a checkpoint made for another config stops with one line naming
both files.
"""

from __future__ import annotations

from pathlib import Path

import torch
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf

from grace.errors import UserError
from grace.model.module import GraceModule

KEPT_CONFIG = "config.yaml"
"""The resolved config of a training run, kept in its folder beside `checkpoints/` so that the
model can be rebuilt later (task=plan)."""

CHECKPOINT = Path("checkpoints") / "best.ckpt"
"""The best checkpoint of a training run, under its folder."""


def checkpoint_weights(path: str | Path) -> dict:
    """The module weights of a Lightning checkpoint this project wrote (a full pickle, which
    Lightning needs for the objects it stores: our own files are trusted)."""
    return torch.load(path, map_location="cpu", weights_only=False)["state_dict"]


def find_checkpoint(path: str | Path, fold: int = 0) -> Path:
    """The checkpoint `path` names: a .ckpt file, a train run folder or an experiment run folder
    (its `fold_<fold>`)."""
    path = Path(path)
    candidates = [path] if path.suffix == ".ckpt" else [path / CHECKPOINT]
    candidates.append(path / f"fold_{fold}" / CHECKPOINT)
    found = next((c for c in candidates if c.is_file()), None)
    if found is None:
        raise UserError(
            f"ckpt={path}: no checkpoint there (looked for {', '.join(map(str, candidates))}); "
            "fix: pass a .ckpt file or the folder of a train or experiment run"
        )
    return found


def load_model(ckpt: Path) -> tuple[GraceModule, DictConfig]:
    """The module rebuilt from the config kept beside `ckpt`, with the checkpoint's weights."""
    kept = ckpt.parent.parent / KEPT_CONFIG
    if not kept.is_file():
        raise UserError(
            f"ckpt={ckpt}: no {KEPT_CONFIG} beside it ({kept}); fix: use a checkpoint of a run "
            f"that kept its config (every train and experiment run writes one)"
        )
    cfg = OmegaConf.load(kept)
    try:
        state = checkpoint_weights(ckpt)
    except Exception as e:
        raise UserError(
            f"ckpt={ckpt}: not a readable Lightning checkpoint ({type(e).__name__}: {e}); "
            "fix: pass the best.ckpt a train or experiment run wrote"
        ) from None
    module = instantiate(cfg.model)
    try:
        module.load_state_dict(state, strict=True)
    except RuntimeError as e:
        first = str(e).splitlines()[1].strip() if len(str(e).splitlines()) > 1 else str(e)
        raise UserError(
            f"ckpt={ckpt} was made for another config than {kept} ({first}); fix: keep the "
            "checkpoint beside the config.yaml of the run that trained it"
        ) from None
    return module.eval(), cfg
