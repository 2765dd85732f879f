"""Where a training epoch's time goes (`python -m grace task=bench task.profile=true`).

Trains `task.profile_epochs` epochs of the experiment's first fold, on the configured data,
model and trainer, with :class:`grace.model.profiling.StageProfiler` as the trainer's profiler,
and writes each stage's seconds per epoch to `profile.json` (docs/training.md, "Where an epoch's
time goes").
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import torch
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf

from grace.cli.fit import train_module
from grace.cli.folds import protocol_folds, start_fold
from grace.data.atomic import write_text_atomic


def profile_epochs(cfg: DictConfig) -> float:
    """Profile the first fold's first epochs; write profile.json; return the mean epoch's CPU
    seconds."""
    data = instantiate(cfg.dataset).load()
    fold = protocol_folds(cfg, data)[2][0]
    cfg = OmegaConf.merge(cfg, {"trainer": {"max_epochs": cfg.task.profile_epochs}})
    cfg.trainer.profiler = {"_target_": "grace.model.profiling.StageProfiler"}
    start_fold(cfg, fold, int(cfg.threads), os.getpid())
    out_dir = Path(cfg.paths.output_dir)
    train, val = [data[i] for i in fold.train], [data[i] for i in fold.val]
    profiler = train_module(cfg, train, val, out_dir / "profile").trainer.profiler
    result = {
        "epochs": profiler.epochs,
        "threads": torch.get_num_threads(),
        "assemblies": {"train": len(train), "val": len(val)},
        "cpu_s_per_epoch": profiler.stages(),
        "wall_s_per_epoch": profiler.stages(wall=True),
    }
    write_text_atomic(out_dir / "profile.json", json.dumps(result, indent=2) + "\n")
    print(profiler.summary())
    return sum(result["cpu_s_per_epoch"].values())
