import csv

import numpy as np
import torch

from grace.evaluation.metrics import step_auc
from grace.model.module import GraceModule
from grace.model.scoring import make_scorer
from grace.model.training import fit, make_module
from grace.tasks.train import state_scores


def _epochs(path):
    rows = list(csv.DictReader(path.open()))
    return [r for r in rows if r["train_loss"]]


def test_short_training_overfits_a_tiny_set(cfg_factory, samples, tmp_path):
    cfg = cfg_factory(
        "trainer.max_epochs=40",
        "trainer.batch_size=8",
        "trainer.progress_bar=false",
        "trainer.lr_decay=null",
        "seed=0",
    )
    before = step_auc(*state_scores(make_scorer(make_module(cfg)), samples))
    module = fit(cfg, samples, samples, tmp_path / "run")
    assert isinstance(module, GraceModule)
    assert (tmp_path / "run" / "checkpoints" / "best.ckpt").exists()
    rows = _epochs(next((tmp_path / "run" / "logs").glob("version_*/metrics.csv")))
    losses = [float(r["train_loss"]) for r in rows]
    aucs = [float(r["train_step_auc"]) for r in rows]
    assert losses[-1] < 0.7 * losses[0]
    assert np.mean(aucs[-3:]) > aucs[0] + 0.2
    after = step_auc(*state_scores(make_scorer(module), samples))
    assert after > before + 0.2


def test_lr_decay_watches_the_early_stopping_monitor(cfg_factory):
    constant = make_module(cfg_factory("trainer.lr_decay=null")).configure_optimizers()
    assert isinstance(constant, torch.optim.Adam)
    module = make_module(cfg_factory("trainer.lr_decay.factor=0.25"))
    module.monitor, module.monitor_mode = "val_step_auc", "max"
    config = module.configure_optimizers()
    decay = config["lr_scheduler"]["scheduler"]
    assert isinstance(decay, torch.optim.lr_scheduler.ReduceLROnPlateau)
    assert config["lr_scheduler"]["monitor"] == "val_step_auc"
    assert decay.mode == "max" and decay.factor == 0.25
