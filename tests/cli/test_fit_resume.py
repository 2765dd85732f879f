"""A fit killed at any point and rerun with the same config resumes from `last.ckpt` and ends
with the weights of an uninterrupted fit (grace/model/resume.py, grace/cli/fit.py)."""

import lightning.pytorch as pl
import pytest
import torch

from grace.cli.fit import train_module
from grace.errors import UserError

SETTINGS = (
    "trainer.max_epochs=4",
    "datamodule.batch_size=8",
    "trainer.enable_progress_bar=false",
    "model.graph.pe=random",  # randomised encodings: their generator must resume too
    "seed=0",
    "model.net.hidden=8",
    "model.net.surface_blocks=1",
)


class Killed(Exception):
    """Stands for SIGKILL: the fit ends here, leaving whatever is on disk."""


class KillAt(pl.Callback):
    """Raises in the middle of epoch `epoch` (its first batch is done, its checkpoint is not)."""

    def __init__(self, epoch: int) -> None:
        self.epoch = epoch

    def on_train_batch_end(self, trainer, *args) -> None:
        if trainer.current_epoch == self.epoch:
            raise Killed


def _fit(cfg, train, val, out, **kwargs):
    """One fold's training as run_fold does it: seeded first."""
    pl.seed_everything(0, verbose=False)
    return train_module(cfg, train, val, out, **kwargs)


def _weights(module) -> dict[str, torch.Tensor]:
    return {k: v.clone() for k, v in module.state_dict().items()}


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize("kill_epoch", [1, pytest.param(3, marks=pytest.mark.slow)])
def test_a_killed_fit_resumes_to_the_uninterrupted_weights(
    cfg_factory, samples, tmp_path, kill_epoch
):
    cfg = cfg_factory(*SETTINGS)
    train, val = samples[:5], samples[5:]
    whole = _weights(_fit(cfg, train, val, tmp_path / "whole"))
    run = tmp_path / "killed"
    with pytest.raises(Killed):
        _fit(cfg, train, val, run, callbacks=[KillAt(kill_epoch)])
    assert (run / "checkpoints" / "last.ckpt").exists()
    resumed = _weights(_fit(cfg, train, val, run))
    assert _same(resumed, whole)


def test_a_checkpoint_of_another_config_is_refused(cfg_factory, samples, tmp_path):
    train, val = samples[:5], samples[5:]
    run = tmp_path / "run"
    with pytest.raises(Killed):
        _fit(cfg_factory(*SETTINGS), train, val, run, callbacks=[KillAt(1)])
    other = cfg_factory(*SETTINGS, "model.optimizer.lr=0.01")
    with pytest.raises(UserError, match=r"last\.ckpt was written by a run of another config"):
        _fit(other, train, val, run)


def test_last_ckpt_holds_the_latest_epoch_even_when_it_was_not_the_best(
    cfg_factory, samples, tmp_path
):
    """A resume goes on after the last finished epoch instead of repeating the epochs since the
    best one (at lr 0 the validation loss never improves after epoch 0)."""
    cfg = cfg_factory(*SETTINGS, "model.optimizer.lr=0")
    with pytest.raises(Killed):
        _fit(cfg, samples[:5], samples[5:], tmp_path, callbacks=[KillAt(3)])
    best, last = (
        torch.load(tmp_path / "checkpoints" / f"{name}.ckpt", weights_only=False)["epoch"]
        for name in ("best", "last")
    )
    assert (best, last) == (0, 2)
