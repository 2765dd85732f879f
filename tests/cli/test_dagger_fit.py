import pytest
from omegaconf import open_dict

from grace.cli.dagger_fit import train_dagger

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)


def test_dagger_round_trains_twice(cfg_factory, fake_simulator, samples, tmp_path):
    """A first model in round_0, then the model trained with the states its planner visited."""
    cfg = cfg_factory("trainer.max_epochs=1", "trainer.enable_progress_bar=false", "threads=1")
    with open_dict(cfg):
        cfg.simulator = fake_simulator
    train_dagger(cfg, samples[:5], samples[5:], tmp_path)
    assert (tmp_path / "round_0" / "checkpoints" / "best.ckpt").exists()
    assert (tmp_path / "checkpoints" / "best.ckpt").exists()
