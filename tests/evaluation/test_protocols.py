import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import OmegaConf

from grace import CONF_DIR
from grace.errors import UserError
from grace.evaluation.protocols import (
    make_folds,
    protocol_sizes,
    split_assemblies,
    training_subset,
)

SIZES = [3] * 40 + [4] * 30 + [5] * 50 + [6] * 20 + [7] * 9


def _check(folds, train_sizes, test_sizes):
    sizes = np.array(SIZES)
    tested = []
    for fold in folds:
        train, val, test = set(fold.train), set(fold.val), set(fold.test)
        assert not train & test and not val & test and not train & val
        assert set(sizes[list(train | val)]) <= set(train_sizes)
        assert set(sizes[list(test)]) <= set(test_sizes)
        tested += fold.test
        for size in train_sizes:  # ~15 % of each size's training assemblies validate
            n_val = (sizes[list(val)] == size).sum()
            n_fit = (sizes[list(train | val)] == size).sum()
            assert n_val == round(0.15 * n_fit)
    # every test-size assembly is tested exactly once over the folds
    assert sorted(tested) == [i for i, s in enumerate(SIZES) if s in test_sizes]


@pytest.mark.parametrize(
    "protocol,top,expected",
    [
        ("intra", {}, ([3, 4, 5, 6, 7], [3, 4, 5, 6, 7])),
        ("many_to_one", {"test_size": 6}, ([3, 4, 5, 7], [6])),
        ("one_to_many", {"train_size": 5}, ([5], [3, 4, 6, 7])),
    ],
)
def test_protocol_configs_and_folds(protocol, top, expected):
    conf = OmegaConf.create({"train_size": 5, "test_size": 5, **top})
    conf.protocol = OmegaConf.load(CONF_DIR / "protocol" / f"{protocol}.yaml")
    p = conf.protocol
    train_sizes, test_sizes = protocol_sizes(
        p.name, SIZES, p.train_sizes, p.test_sizes, p.train_exclude, p.test_exclude
    )
    assert (train_sizes, test_sizes) == expected
    folds = make_folds(SIZES, train_sizes, test_sizes, p.folds, p.val_fraction, p.seed)
    assert len(folds) == p.folds == 4
    _check(folds, train_sizes, test_sizes)


def test_folds_are_fixed_by_seed_and_stratified():
    a = make_folds(SIZES, [3, 4, 5, 6, 7], [3, 4, 5, 6, 7], 4, 0.15, seed=0)
    assert a == make_folds(SIZES, [3, 4, 5, 6, 7], [3, 4, 5, 6, 7], 4, 0.15, seed=0)
    assert a != make_folds(SIZES, [3, 4, 5, 6, 7], [3, 4, 5, 6, 7], 4, 0.15, seed=1)
    sevens = [sum(SIZES[i] == 7 for i in fold.test) for fold in a]
    assert sorted(sevens) == [2, 2, 2, 3]


def test_bad_protocol_settings_fail_clearly():
    with pytest.raises(ValueError, match=r"sizes \[9\] are not in the data set"):
        protocol_sizes("many_to_one", SIZES, None, [9], [9])
    with pytest.raises(ValueError, match="at least 2 folds"):
        make_folds(SIZES, [3], [3], 1, 0.15, 0)


def test_feasible_only_training_subset(fake_simulator):
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(0)
    samples = [simulator.sample(5, rng) for _ in range(30)]
    feasible = training_subset(samples, feasible_only=True)
    assert feasible == [s for s in samples if s.truth.feasible]
    assert 0 < len(feasible) < len(samples)
    assert training_subset(samples, feasible_only=False) == samples


@pytest.fixture
def samples_by_size(fake_simulator):
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(0)
    return [simulator.sample(n, rng) for n in (3, 4, 5) for _ in range(10)]


def test_split_holds_out_whole_assemblies_per_size(samples_by_size):
    train, val, test = split_assemblies(samples_by_size, 0.15, 0.15, seed=0)
    ids = [{id(s) for s in part} for part in (train, val, test)]
    assert not (ids[0] & ids[1] or ids[0] & ids[2] or ids[1] & ids[2])
    assert sum(map(len, ids)) == len(samples_by_size)
    assert {s.size for s in test} == {s.size for s in samples_by_size}
    again = split_assemblies(samples_by_size, 0.15, 0.15, seed=0)
    assert [id(s) for s in again[2]] == [id(s) for s in test]
    with pytest.raises(UserError, match=r"task\.test_fraction"):
        split_assemblies(samples_by_size, 1.5, 0.15, seed=0)
