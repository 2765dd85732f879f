"""A fit killed at any point and rerun with the same config resumes from `last.ckpt` and ends
exactly as an uninterrupted fit: the same weights, and every epoch after the kill logs the same
metrics with the same lr (grace/model/resume.py, grace/cli/fit.py).

Every end-of-epoch update must decide during the fit: a plateau scheduler (a state its step
changes) lowers the lr twice and early stopping ends the fit before `max_epochs`. Both watch a
metric this test scripts by epoch (`Scripted`), so they act at the same epochs on every CPU; a
fit watching its own validation loss reached the second lr drop on one CPU's kernels and not on
another's. A fit that runs only a few epochs at a constant lr (as this test once did) cannot see
a scheduler state saved before its step.
"""

import lightning.pytorch as pl
import pytest
import torch

from grace.cli.fit import train_module
from grace.errors import UserError

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)

SETTINGS = (
    "trainer.max_epochs=12",
    "datamodule.batch_size=8",
    "trainer.enable_progress_bar=false",
    "model.graph.pe=random",  # randomised encodings: their generator must resume too
    "seed=0",
    "model.net.hidden=8",
    "model.net.surface_blocks=1",
    "model.optimizer.lr=0.05",
    "model/scheduler=plateau",  # a scheduler with a state that its step changes
    "model.scheduler.patience=1",
    "callbacks.early_stopping.patience=5",
)
SCRIPTED = (*SETTINGS, "monitor.metric=scripted")
"""Early stopping, the best checkpoint and the scheduler watch `Scripted`'s metric."""


class Scripted(pl.Callback):
    """Logs `scripted` after each validation, a value fixed by the epoch: the plateau scheduler
    (patience 1) halves the lr after epochs 3 and 5, and early stopping (patience 5) ends the fit
    after epoch 6. The value stays at its best after the first drop, so a fit resumed at that
    drop goes on as the uninterrupted one only with the scheduler's state restored (a fresh
    scheduler would count epoch 4 as an improvement and drop the lr one epoch late)."""

    VALUES = (3.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0)

    def on_validation_epoch_end(self, trainer, pl_module) -> None:
        pl_module.log("scripted", self.VALUES[trainer.current_epoch])


class Killed(Exception):
    """Stands for SIGKILL: the fit ends here, leaving whatever is on disk."""


class KillAt(pl.Callback):
    """Raises after the first batch of epoch `epoch` (its checkpoint is not written yet)."""

    def __init__(self, epoch: int) -> None:
        self.epoch = epoch

    def on_train_batch_end(self, trainer, *args) -> None:
        if trainer.current_epoch == self.epoch:
            raise Killed


class KillAfterLrStep(pl.Callback):
    """Raises at the first batch trained with a lowered lr: right after the scheduler's step."""

    def on_train_batch_start(self, trainer, *args) -> None:
        if not hasattr(self, "lr"):
            self.lr = trainer.optimizers[0].param_groups[0]["lr"]
        elif trainer.optimizers[0].param_groups[0]["lr"] < self.lr:
            raise Killed


class Epochs(pl.Callback):
    """Per finished epoch, once all of its end has run: its metrics, the lr its batches used and
    the scheduler's state after its step."""

    def __init__(self) -> None:
        self.rows: dict[int, dict] = {}
        self.ended = False

    def on_train_batch_start(self, trainer, *args) -> None:
        self.lr = trainer.optimizers[0].param_groups[0]["lr"]

    def on_train_epoch_end(self, trainer, pl_module) -> None:
        self.ended = True

    def _record(self, trainer, epoch: int) -> None:
        if self.ended:
            scheduler = trainer.lr_scheduler_configs[0].scheduler
            self.rows[epoch] = {
                "lr": self.lr,
                "bad_epochs": scheduler.num_bad_epochs,
                **{k: float(v) for k, v in trainer.callback_metrics.items()},
            }
        self.ended = False

    def on_train_epoch_start(self, trainer, pl_module) -> None:
        self._record(trainer, trainer.current_epoch - 1)

    def on_train_end(self, trainer, pl_module) -> None:
        self._record(trainer, trainer.current_epoch - 1)


def _fit(cfg, train, val, out, *callbacks):
    """One fold's training as run_fold does it: seeded first."""
    pl.seed_everything(0, verbose=False)
    epochs = Epochs()
    module = train_module(cfg, train, val, out, callbacks=[Scripted(), epochs, *callbacks])
    return {k: v.clone() for k, v in module.state_dict().items()}, epochs.rows


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


_WHOLE: dict[str, tuple] = {}
"""The uninterrupted fit, run once per session: its results do not depend on its folder."""


@pytest.fixture
def whole(cfg_factory, samples, tmp_path):
    """The uninterrupted fit: its config, data, folder, weights and epochs."""
    if not _WHOLE:
        cfg = cfg_factory(*SCRIPTED)
        train, val = samples[:5], samples[5:]
        weights, rows = _fit(cfg, train, val, tmp_path / "whole")
        lrs = [row["lr"] for row in rows.values()]
        assert lrs == [0.05] * 4 + [0.025] * 2 + [0.0125], "the scripted schedule did not hold"
        _WHOLE["fit"] = (cfg, train, val, tmp_path / "whole", weights, rows)
    return _WHOLE["fit"]


@pytest.mark.parametrize(
    "kills",
    [
        pytest.param([KillAfterLrStep()], id="after-lr-step"),
        pytest.param(
            [KillAt(2), KillAt(5), KillAfterLrStep()], id="three-kills", marks=pytest.mark.slow
        ),
    ],
)
def test_a_killed_fit_resumes_to_the_uninterrupted_fit(whole, tmp_path, kills):
    cfg, train, val, _, weights, rows = whole
    run = tmp_path / "killed"
    seen: dict[int, dict] = {}
    for kill in kills:
        epochs = Epochs()
        with pytest.raises(Killed):
            pl.seed_everything(0, verbose=False)
            train_module(cfg, train, val, run, callbacks=[Scripted(), epochs, kill])
        seen |= epochs.rows
        assert (run / "checkpoints" / "last.ckpt").exists()
    resumed, after = _fit(cfg, train, val, run)
    assert _same(resumed, weights)
    assert seen | after == rows  # every epoch's metrics, lr and scheduler state


def test_a_finished_fit_rerun_trains_no_further_epoch(whole):
    """A kill after early stopping ended the fit (before the fold's results were written): the
    rerun ends the fit at once with the same best weights."""
    cfg, train, val, folder, weights, _ = whole
    again, after = _fit(cfg, train, val, folder)
    assert after == {}
    assert _same(again, weights)


def test_a_checkpoint_of_another_config_is_refused(cfg_factory, samples, tmp_path):
    train, val = samples[:5], samples[5:]
    run = tmp_path / "run"
    with pytest.raises(Killed):
        _fit(cfg_factory(*SETTINGS), train, val, run, KillAt(1))
    other = cfg_factory(*SETTINGS, "model.optimizer.lr=0.01")
    with pytest.raises(UserError, match=r"last\.ckpt was written by a run of another config"):
        _fit(other, train, val, run)


def test_last_ckpt_holds_the_latest_epoch_even_when_it_was_not_the_best(
    cfg_factory, samples, tmp_path
):
    """A resume goes on after the last finished epoch instead of repeating the epochs since the
    best one (at lr 0 the validation loss never improves after epoch 0)."""
    cfg = cfg_factory(*SETTINGS, "model.optimizer.lr=0", "callbacks.early_stopping.patience=10")
    with pytest.raises(Killed):
        _fit(cfg, samples[:5], samples[5:], tmp_path, KillAt(3))
    best, last = (
        torch.load(tmp_path / "checkpoints" / f"{name}.ckpt", weights_only=False)["epoch"]
        for name in ("best", "last")
    )
    assert (best, last) == (0, 3)  # last: written as epoch 3 began, after epoch 2's every update
