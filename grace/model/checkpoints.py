"""Checkpoints this project writes, and the models rebuilt from them (task=plan).

A training run keeps its resolved config in its folder beside `checkpoints/`
(grace/model/kept.py), so a model is rebuilt from that config and the checkpoint's weights must
fit it exactly: a checkpoint made for another config stops with one line naming both files.
"""

from __future__ import annotations

from pathlib import Path

import torch
from hydra.utils import instantiate
from omegaconf import DictConfig

from grace.errors import UserError
from grace.model.grace_pyg import Score
from grace.model.kept import kept_config
from grace.model.module import GraceModule


def checkpoint_weights(path: str | Path) -> dict:
    """The module weights of a Lightning checkpoint this project wrote (a full pickle, which
    Lightning needs for the objects it stores: our own files are trusted)."""
    return torch.load(path, map_location="cpu", weights_only=False)["state_dict"]


def load_model(ckpt: Path) -> tuple[GraceModule, DictConfig]:
    """The module rebuilt from the config kept beside `ckpt`, with the checkpoint's weights."""
    kept, cfg = kept_config(ckpt)
    if "score" not in cfg.model.net:  # kept before the score was a key: those runs planned
        cfg.model.net.score = Score.geometric.value  # with the geometric mean
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
