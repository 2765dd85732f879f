import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import open_dict

from grace.cli.dagger_fit import train_dagger


@pytest.fixture
def samples(fake_simulator):
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(3)
    return [simulator.sample(n, rng) for n in (3, 4, 5, 4, 5)]


def _brute_force_label(truth, state):
    try:
        return truth.label(state)
    except KeyError:  # no feasible placement reaches it: nothing completes from there
        return 0


def test_dagger_round_trains_twice(cfg_factory, fake_simulator, samples, tmp_path):
    cfg = cfg_factory("trainer.max_epochs=1", "trainer.enable_progress_bar=false", "threads=1")
    with open_dict(cfg):
        cfg.simulator = fake_simulator
    train_dagger(cfg, samples[:4], samples[4:], tmp_path)
    assert (tmp_path / "round_0" / "checkpoints" / "best.ckpt").exists()
    assert (tmp_path / "checkpoints" / "best.ckpt").exists()
