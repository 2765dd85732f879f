import csv

import numpy as np
import pytest
import torch
from hydra.utils import instantiate
from omegaconf import OmegaConf

from grace.cli.fit import kept_module, train_module
from grace.errors import UserError
from grace.evaluation.metrics import step_auc
from grace.evaluation.step_states import state_scores
from grace.model.checkpoints import load_model
from grace.model.grace_fast import fast_logits, one_assembly_states
from grace.model.grace_pyg import Score
from grace.model.loss import grace_loss
from grace.model.module import GraceModule
from grace.model.module import step_auc as logged_step_auc
from grace.model.scoring import make_scorer

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)


def _epochs(path):
    rows = list(csv.DictReader(path.open()))
    return [r for r in rows if r["train_loss"]]


def test_short_training_overfits_a_tiny_set(cfg_factory, samples, tmp_path):
    cfg = cfg_factory(
        "trainer.max_epochs=20",
        "datamodule.batch_size=8",
        "trainer.enable_progress_bar=false",
        "model.scheduler=null",
        "seed=0",
    )
    before = step_auc(*state_scores(make_scorer(instantiate(cfg.model)), samples))
    module = train_module(cfg, samples, samples, tmp_path / "run")
    assert isinstance(module, GraceModule)
    assert (tmp_path / "run" / "checkpoints" / "best.ckpt").exists()
    rows = _epochs(next((tmp_path / "run" / "logs").glob("version_*/metrics.csv")))
    losses = [float(r["train_loss"]) for r in rows]
    aucs = [float(r["train_step_auc"]) for r in rows]
    assert losses[-1] < 0.7 * losses[0]
    assert np.mean(aucs[-3:]) > aucs[0] + 0.2
    after = step_auc(*state_scores(make_scorer(module), samples))
    assert after > before + 0.2


def test_the_logged_step_auc_is_the_evaluation_metric():
    rng = np.random.default_rng(0)
    for _ in range(5):
        scores, labels = rng.random(400).round(2), rng.random(400) < 0.3
        logged = logged_step_auc(torch.tensor(scores), torch.tensor(labels))
        assert abs(float(logged) - step_auc(scores, labels)) < 1e-6  # float32 in torchmetrics
    assert logged_step_auc(torch.rand(5), torch.zeros(5)) is None


def test_the_checkpoint_rebuilds_the_module_without_the_config(cfg_factory, samples, tmp_path):
    cfg = cfg_factory("trainer.max_epochs=2", "trainer.enable_progress_bar=false")
    module = train_module(cfg, samples, samples, tmp_path / "run")
    best = tmp_path / "run" / "checkpoints" / "best.ckpt"
    loaded = GraceModule.load_from_checkpoint(best, weights_only=False)
    states = samples[1].truth.states
    np.testing.assert_array_equal(
        make_scorer(loaded)(samples[1].assembly, states),
        make_scorer(module)(samples[1].assembly, states),
    )


def test_without_validation_the_training_loss_is_monitored(cfg_factory, samples, tmp_path):
    cfg = cfg_factory("trainer.max_epochs=3", "trainer.enable_progress_bar=false")
    train_module(cfg, samples, [], tmp_path / "run")
    rows = list(csv.DictReader(next((tmp_path / "run").glob("logs/version_*/metrics.csv")).open()))
    assert rows and not any(r.get("val_loss") for r in rows)
    assert (tmp_path / "run" / "checkpoints" / "best.ckpt").exists()


def test_lr_decay_watches_the_early_stopping_monitor(cfg_factory):
    constant = instantiate(cfg_factory("model.scheduler=null").model).configure_optimizers()
    assert isinstance(constant, torch.optim.Adam)
    cfg = cfg_factory(
        "model/scheduler=plateau",
        "model.scheduler.factor=0.25",
        "monitor.metric=val_step_auc",
        "monitor.mode=max",
    )
    config = instantiate(cfg.model).configure_optimizers()
    decay = config["lr_scheduler"]["scheduler"]
    assert isinstance(decay, torch.optim.lr_scheduler.ReduceLROnPlateau)
    assert config["lr_scheduler"]["monitor"] == "val_step_auc"
    assert decay.mode == "max" and decay.factor == 0.25
    assert instantiate(cfg.callbacks.early_stopping).monitor == "val_step_auc"


def test_the_default_schedule_ends_by_plan(cfg_factory):
    """The default lr follows half a cosine from model.optimizer.lr to 0 over exactly
    trainer.max_epochs epochs, whatever the validation does."""
    cfg = cfg_factory("trainer.max_epochs=4")
    config = instantiate(cfg.model).configure_optimizers()
    optimizer, schedule = config["optimizer"], config["lr_scheduler"]["scheduler"]
    lrs = []
    for _ in range(5):
        lrs.append(optimizer.param_groups[0]["lr"])
        optimizer.step()
        schedule.step()
    lr = cfg.model.optimizer.lr
    expected = [lr * (1 + np.cos(np.pi * e / 4)) / 2 for e in range(5)]
    np.testing.assert_allclose(lrs, expected, atol=1e-12)
    assert lrs[-1] == 0.0


def test_a_fit_without_validation_watches_the_training_loss(cfg_factory, samples, tmp_path):
    """No validation assemblies: early stopping and the best checkpoint watch train_loss (the
    monitor wiring of grace/cli/fit.py); the best checkpoint is the lowest train_loss."""
    cfg = cfg_factory(
        "trainer.max_epochs=3",
        "trainer.enable_progress_bar=false",
        "model.net.hidden=8",
        "model.net.surface_blocks=1",
    )
    module = train_module(cfg, samples, [], tmp_path / "run")
    assert isinstance(module, GraceModule)
    best = torch.load(tmp_path / "run" / "checkpoints" / "best.ckpt", weights_only=False)
    rows = _epochs(next((tmp_path / "run" / "logs").glob("version_*/metrics.csv")))
    losses = [float(r["train_loss"]) for r in rows]
    assert len(losses) == 3 and "val_loss" not in {k for r in rows for k, v in r.items() if v}
    assert best["epoch"] == int(np.argmin(losses))


def test_two_heads_train_next_step_and_placeable_outputs_on_their_own_targets(cfg_factory, samples):
    """With the placeable head the loss is the next-step loss on the graded labels (with the
    state weights) plus the placeable output's loss on the placeable mask (unweighted)."""
    cfg = cfg_factory(
        "model.net.pair_readout=8", "model.net.pair_geometry=6", "model.net.placeable_head=true"
    )
    module = instantiate(cfg.model)
    dm = instantiate(cfg.datamodule)(samples, samples, enc=module.enc, collate=module.impl.collate)
    batch = next(iter(dm.train_dataloader()))
    assert batch.weights is not None and batch.placeable is not None
    logged = {}
    module.log = lambda name, value, **kw: logged.setdefault(name, value)
    loss = module.training_step(batch, 0)
    logits = module(batch)
    assert logits.shape == (*batch.mask.shape, 2)
    step = grace_loss(
        logits[..., 0], batch.labels, batch.flags, batch.mask, module.delta, batch.weights
    )
    place = grace_loss(logits[..., 1], batch.placeable, batch.flags, batch.mask, module.delta)
    torch.testing.assert_close(loss, step + place)
    assert not torch.equal(batch.placeable, batch.labels)


def test_a_kept_checkpoint_plans_again_under_another_score(cfg_factory, samples, tmp_path):
    """task.checkpoints: the fold's weights, the current config's score rule; a config that
    trains differently is refused naming the key."""
    train = ("trainer.max_epochs=1", "trainer.enable_progress_bar=false")
    module = train_module(cfg_factory(*train), samples, samples, tmp_path / "run")
    again = kept_module(cfg_factory(*train, "model.net.score=geometric"), tmp_path / "run")
    assert again.net.cfg.score is Score.geometric and module.net.cfg.score is Score.min
    for name, weights in module.state_dict().items():
        torch.testing.assert_close(again.state_dict()[name], weights)
    sample = samples[1]
    dense = make_scorer(module)._prepared(sample.assembly).dense
    logits = fast_logits(module.net, dense, *one_assembly_states(dense, sample.truth.states))
    np.testing.assert_allclose(
        make_scorer(again)(sample.assembly, sample.truth.states),
        torch.sigmoid(logits).prod(dim=-1).sqrt().detach().numpy(),
        atol=1e-6,
    )
    # task=experiment never plans with the verified search: a later planner default re-plans
    kept_module(cfg_factory(*train, "planner.exhaustive_after=20"), tmp_path / "run")
    with pytest.raises(UserError, match=r"model\.net\.hidden \(kept 94, now 32\)"):
        kept_module(cfg_factory(*train, "model.net.hidden=32"), tmp_path / "run")
    with pytest.raises(UserError, match=r"dataset\.seed \(kept 0, now 1\)"):
        kept_module(cfg_factory(*train, "experiment=selection"), tmp_path / "run")
    with pytest.raises(UserError, match=r"no checkpoints/best\.ckpt"):
        kept_module(cfg_factory(*train), tmp_path / "nowhere")
    # a key newer than the run compares equal while it is off, and refuses when it is on
    kept = OmegaConf.load(tmp_path / "run" / "config.yaml")
    del kept.model.net["extra_part_features"]
    OmegaConf.save(kept, tmp_path / "run" / "config.yaml")
    kept_module(cfg_factory(*train), tmp_path / "run")
    with pytest.raises(UserError, match=r"extra_part_features \(kept None, now 10\)"):
        kept_module(cfg_factory(*train, "model.net.extra_part_features=10"), tmp_path / "run")
    # a run kept before the score was a key planned with the geometric mean: task=plan keeps it
    kept = OmegaConf.load(tmp_path / "run" / "config.yaml")
    del kept.model.net["score"]
    OmegaConf.save(kept, tmp_path / "run" / "config.yaml")
    older, _ = load_model(tmp_path / "run" / "checkpoints" / "best.ckpt")
    assert older.net.cfg.score is Score.geometric
    # rebuilt without PyG (parameter holders the fast path reads): the same scores, bit for bit
    assert not isinstance(older, GraceModule) and "GATv2Weights" in repr(older.net)
    scores = make_scorer(again)(sample.assembly, sample.truth.states)
    assert np.array_equal(make_scorer(older)(sample.assembly, sample.truth.states), scores)
