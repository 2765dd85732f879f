"""A stand-in trainer for tune tests: no network, a validation curve known in closed form.

`fit` drives its callbacks as Lightning's Trainer does after each validation epoch
(`on_validation_end` with `callback_metrics` and the module's `current_epoch`), so the tune's
metric recorder and optuna-integration's pruning callback run their real code.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import torch

BEST_LR = 3e-3


def quality(lr: float, hidden: int) -> float:
    """The fake's final validation metric: best at lr = BEST_LR and a large `hidden`."""
    return 1.0 - (math.log10(lr) - math.log10(BEST_LR)) ** 2 / 4 - (128 - hidden) / 1000


def curve(cfg) -> list[tuple[float, float]]:
    """(val_step_auc, val_loss) per epoch: rises to `quality`; the loss is lowest one epoch
    before the end, so the kept epoch is not the last."""
    q, epochs = quality(cfg.model.optimizer.lr, cfg.model.net.hidden), cfg.trainer.max_epochs
    out = [(q * (e + 1) / epochs, 1.0 - (e + 1) / epochs) for e in range(epochs)]
    out[-1] = (out[-1][0], out[-2][1] + 0.01)
    return out


def kept_value(cfg) -> float:
    """The tune's value of a trial run with `cfg` (every fold alike): the metric of the epoch
    with the lowest loss."""
    return min(curve(cfg), key=lambda row: row[1])[0]


def fit(cfg, train, val, out_dir, callbacks=()):
    trainer = SimpleNamespace(sanity_checking=False, callback_metrics={})
    module = SimpleNamespace(current_epoch=0)
    for epoch, (auc, loss) in enumerate(curve(cfg)):
        module.current_epoch = epoch
        metrics = {"val_step_auc": auc, "val_loss": loss}
        trainer.callback_metrics = {k: torch.tensor(v) for k, v in metrics.items()}
        for callback in callbacks:
            callback.on_validation_end(trainer, module)
    return None
