"""`python -m grace task=train`: train GRACE on a data set and report held-out step AUC.

Assemblies (not states) are held out: per size, a seeded `task.test_fraction` for testing, then
`task.val_fraction` of the rest for early stopping. Writes `metrics.json` next to the checkpoint in
the run's output folder and returns the held-out step AUC over all sizes.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig

from grace.cli.runner import TaskSettings
from grace.data.atomic import write_json_atomic
from grace.evaluation.metrics import step_auc
from grace.evaluation.protocols import split_assemblies
from grace.evaluation.step_states import state_scores
from grace.model.grace_pyg import count_parameters
from grace.model.scoring import make_scorer
from grace.roles import WEIGHTS

log = logging.getLogger(__name__)


@dataclass
class TrainSettings(TaskSettings):
    """Schema of `task=train` (values in grace/conf/task/train.yaml)."""

    # (cfg, train, val, out_dir) -> trained module, a partial
    fit: Any = field(default=MISSING, metadata=WEIGHTS)
    test_fraction: float = field(default=MISSING, metadata=WEIGHTS)
    val_fraction: float = field(default=MISSING, metadata=WEIGHTS)


def _finite(x: float) -> float | None:
    """JSON has no NaN: an undefined AUC (no positive label) is written as null."""
    return None if np.isnan(x) else x


def run(cfg: DictConfig) -> float:
    out_dir = Path(cfg.paths.output_dir)
    start = time.perf_counter()
    samples = instantiate(cfg.dataset).load()
    train, val, test = split_assemblies(
        samples, float(cfg.task.test_fraction), float(cfg.task.val_fraction), int(cfg.seed)
    )
    log.info("assemblies: %d train, %d val, %d test", len(train), len(val), len(test))
    module = instantiate(cfg.task.fit)(cfg, train, val, out_dir)
    scorer = make_scorer(module)
    per_size: dict[str, float | None] = {}
    for size in sorted({s.size for s in test}):
        auc = step_auc(*state_scores(scorer, [s for s in test if s.size == size]))
        per_size[str(size)] = _finite(auc)
        print(f"A{size}: held-out step AUC {auc:.4f}")
    overall = step_auc(*state_scores(scorer, test)) if test else float("nan")
    print(f"all sizes: held-out step AUC {overall:.4f}")
    checkpoint = out_dir / "checkpoints" / "best.ckpt"
    metrics = {
        "step_auc": {"all": _finite(overall), "per_size": per_size},
        "assemblies": {"train": len(train), "val": len(val), "test": len(test)},
        "params": count_parameters(module.net),
        "model": module.name,
        "impl": module.impl.name,
        "checkpoint": str(checkpoint) if checkpoint.exists() else None,
        "seconds": time.perf_counter() - start,
    }
    write_json_atomic(out_dir / "metrics.json", metrics)
    return overall
