import itertools
import json

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.utils import instantiate

from grace import CONF_DIR
from grace.simulation.simulator import Simulator

INFO_KEYS = {"cause", "robot_pruned", "nonlocal_block", "orders", "fixation_orders", "seconds"}


def _check_info(sample) -> None:
    info = sample.info
    assert set(info) >= INFO_KEYS
    json.dumps(info)
    assert info["orders"] == sample.truth.n_orders()
    if sample.truth.feasible:
        assert info["cause"] is None
        assert info["robot_pruned"] == (info["orders"] < info["fixation_orders"])
    else:
        assert info["cause"] in {"reach", "collision", "other"}
        assert not info["robot_pruned"] and not info["nonlocal_block"]


def test_fake_cell_samples_are_deterministic_and_diagnosed(fake_sim):
    a = [fake_sim.sample(n, np.random.default_rng(n)) for n in (3, 5, 6)]
    b = [fake_sim.sample(n, np.random.default_rng(n)) for n in (3, 5, 6)]
    for x, y in zip(a, b, strict=True):
        assert x.assembly == y.assembly and x.truth == y.truth
        _check_info(x)


def test_fake_cell_replay_agrees_with_cache_on_generated_assemblies(fake_sim):
    rng = np.random.default_rng(11)
    for _ in range(4):
        sample = fake_sim.sample(5, rng)
        listed = set(sample.truth.orders())
        for order in itertools.permutations(range(5)):
            assert (fake_sim.replay(sample.assembly, order) is None) == (order in listed)


# --- the real robot cell ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def real_sim() -> Simulator:
    pytest.importorskip("grace.simulation.robot_cell")
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR / "simulator"), version_base="1.3"):
        cfg = compose(config_name="dual_arm")
    GlobalHydra.instance().clear()
    return instantiate(cfg)


def _before(order, a, b):
    return order.index(a) < order.index(b)


def test_config_builds_the_simulator(real_sim):
    assert isinstance(real_sim, Simulator)
    sample = real_sim.sample(4, np.random.default_rng(0))
    _check_info(sample)
    assert sample.assembly == real_sim.generate(4, np.random.default_rng(0))


def test_real_cell_finger_gap(real_sim, world):
    bar = world.profile(300, 0, 0, along_x=True)
    long_stem = world.profile(300, -40, 170)
    narrow = real_sim.label(world.build(bar, long_stem, world.profile(200, 8, 120)))
    orders = list(narrow.truth.orders())
    assert orders and all(_before(o, 2, 1) for o in orders)
    wide = real_sim.label(world.build(bar, long_stem, world.profile(200, 80, 120)))
    orders = list(wide.truth.orders())
    assert any(_before(o, 2, 1) for o in orders) and any(_before(o, 1, 2) for o in orders)


def test_real_cell_slide_corridor_and_bracket(real_sim, world):
    p = world.profile
    corridor = world.build(
        p(300, 0, 0, True), p(200, 0, 120), p(300, 120, 170), p(200, 0, 270, True)
    )
    orders = list(real_sim.label(corridor).truth.orders())
    assert orders and all(_before(o, 1, 3) for o in orders)
    corner = world.build(p(300, 0, 0, True), p(200, -130, 120), world.bracket(-110, 20, 0))
    orders = list(real_sim.label(corner).truth.orders())
    assert orders and all(o[-1] == 2 for o in orders)


def test_real_cell_out_of_reach_is_infeasible(real_sim, world):
    chain = world.build(*[world.profile(300, 0, 300 * k) for k in range(6)])
    sample = real_sim.label(chain)
    assert not sample.truth.feasible and sample.info["cause"] == "reach"


def test_real_cell_replay_agrees_with_cache(real_sim):
    """Every listed order passes the uncached MuJoCo check step by step; every other fails."""
    rng = np.random.default_rng(9)
    samples = (real_sim.sample(5, rng) for _ in range(40))
    pruned = [s for s in samples if s.info["robot_pruned"] or s.info["cause"] == "collision"]
    assert len(pruned) >= 3
    for sample in pruned[:3]:
        listed = set(sample.truth.orders())
        for order in itertools.permutations(range(5)):
            assert (real_sim.replay(sample.assembly, order) is None) == (order in listed)
