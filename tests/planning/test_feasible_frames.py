"""The feasible-frame generator returns frames that have an order, deterministic per seed,
decided by the ground truth up to its limit and by the verified search above it."""

from types import SimpleNamespace

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.utils import instantiate

from grace import CONF_DIR
from grace.errors import UserError
from grace.planning.feasible_frames import FeasibleFrames
from grace.planning.heuristics import ContactHeuristic
from grace.planning.search import VerifiedSearch
from grace.simulation.cell_config import register


def simulator(name: str):
    register()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(config_name=f"simulator/{name}")
    GlobalHydra.instance().clear()
    return instantiate(cfg.simulator)


@pytest.fixture(scope="module")
def large():
    return simulator("large_frames")


def test_frames_drawn_by_the_ground_truth_are_feasible_and_the_same_per_seed():
    sim = simulator("dual_arm")
    frames = FeasibleFrames(VerifiedSearch(), ContactHeuristic().scorer())
    drawn = [frames.draw(sim, 7, np.random.default_rng(seed)) for seed in (0, 1, 2)]
    assert all(sim.truth(frame).feasible for frame in drawn)
    assert drawn[0] == frames.draw(sim, 7, np.random.default_rng(0))


def test_frames_drawn_by_the_search_have_an_order_in_the_ground_truth(large):
    # The search decides above 8 parts: a sectioned A12 is verified as it grows.
    frames = FeasibleFrames(VerifiedSearch(), ContactHeuristic().scorer(), truth_limit=8)
    frame = frames.draw(large, 12, np.random.default_rng(3))
    assert frame.n_parts == 12 and large.truth(frame).feasible
    assert frame == frames.draw(large, 12, np.random.default_rng(3))


def test_a_size_with_no_feasible_frame_in_its_draws_says_so(large, monkeypatch):
    monkeypatch.setattr(large, "truth", lambda *_, **__: SimpleNamespace(feasible=False))
    frames = FeasibleFrames(VerifiedSearch(), ContactHeuristic().scorer(), tries=2)
    with pytest.raises(UserError, match="no feasible 3-part frame in 2 draws"):
        frames.draw(large, 3, np.random.default_rng(0))
