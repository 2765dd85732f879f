import numpy as np
import pytest
from hydra.errors import ConfigCompositionException, InstantiationException
from hydra.utils import instantiate

from grace.errors import UserError
from grace.graphs.encoding import GraphEncoding, node_ids, sinusoidal_pe

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)

CONFIG_ERRORS = (ConfigCompositionException, InstantiationException)
"""A bad value fails at composition (a type) or at instantiation (a range)."""


def test_sinusoidal_pe_follows_vaswani():
    pe = sinusoidal_pe(np.array([0, 1, 3]), 16)
    assert pe.shape == (3, 16)
    np.testing.assert_allclose(pe[0], np.tile([0.0, 1.0], 8))
    np.testing.assert_allclose(pe[1, :2], [np.sin(1.0), np.cos(1.0)])
    angle = 3 / 10000 ** (2 / 16)
    np.testing.assert_allclose(pe[2, 2:4], [np.sin(angle), np.cos(angle)])


def test_pe_kinds():
    ids = np.arange(4)
    rng = np.random.default_rng(0)
    assert not GraphEncoding(pe="none").encode(ids, None).any()
    a = GraphEncoding(pe="random").encode(ids, rng)
    b = GraphEncoding(pe="random").encode(ids, rng)
    assert a.shape == (4, 16) and not np.allclose(a, b)
    with pytest.raises(ValueError, match="pass a seeded numpy Generator"):
        GraphEncoding(pe="random").encode(ids, None)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("pe", "learned"),
        ("part_pe", "onehot"),
        ("permute_parts", "always"),
        ("part_id_range", 0),
        ("distance_scale", 0.0),
    ],
)
def test_bad_options_name_the_key(cfg_factory, field, value):
    with pytest.raises(CONFIG_ERRORS, match=rf"model\.graph\.{field}"):
        instantiate(cfg_factory(f"model.graph.{field}={value}").model.graph)


PART_OF_SURFACE = np.array([0, 0, 0, 0, 1, 1, 2, 2, 2, 2])
SURFACE_INDEX = np.array([1, 2, 3, 4, 1, 2, 1, 2, 3, 4])


@pytest.mark.parametrize("training", [True, False])
def test_never_keeps_canonical_ids(training):
    parts, surfaces = node_ids(PART_OF_SURFACE, SURFACE_INDEX, 3, GraphEncoding(), training, None)
    assert parts.tolist() == [0, 1, 2]
    assert surfaces.tolist() == SURFACE_INDEX.tolist()


def test_test_time_permutation_applies_only_when_evaluating():
    enc = GraphEncoding(permute_parts="test", permute_surfaces="test")
    rng = np.random.default_rng(3)
    parts, surfaces = node_ids(PART_OF_SURFACE, SURFACE_INDEX, 3, enc, True, rng)
    assert parts.tolist() == [0, 1, 2] and surfaces.tolist() == SURFACE_INDEX.tolist()
    changed = False
    for _ in range(10):
        parts, surfaces = node_ids(PART_OF_SURFACE, SURFACE_INDEX, 3, enc, False, rng)
        assert sorted(parts.tolist()) == [0, 1, 2]
        for p in range(3):  # surface ids are shuffled within their own part only
            own = p == PART_OF_SURFACE
            assert sorted(surfaces[own].tolist()) == sorted(SURFACE_INDEX[own].tolist())
        changed |= parts.tolist() != [0, 1, 2] or surfaces.tolist() != SURFACE_INDEX.tolist()
    assert changed


def test_train_test_permutation_applies_in_training():
    enc = GraphEncoding(permute_parts="train_test")
    rng = np.random.default_rng(0)
    seen = {
        tuple(node_ids(PART_OF_SURFACE, SURFACE_INDEX, 3, enc, True, rng)[0]) for _ in range(20)
    }
    assert len(seen) > 1


@pytest.mark.parametrize("training", [True, False])
def test_a_part_id_range_draws_ordered_ids_below_it(training):
    enc = GraphEncoding(part_id_range=16)
    assert enc.randomised
    draws = [
        node_ids(PART_OF_SURFACE, SURFACE_INDEX, 3, enc, training, np.random.default_rng(s))
        for s in range(30)
    ]
    for parts, surfaces in draws:
        assert parts.tolist() == sorted(set(parts.tolist())) and 0 <= parts.min() < parts.max() < 16
        assert surfaces.tolist() == SURFACE_INDEX.tolist()
    assert max(int(parts.max()) for parts, _ in draws) > 2  # codes a 3-part graph never had
    again = node_ids(PART_OF_SURFACE, SURFACE_INDEX, 3, enc, training, np.random.default_rng(0))
    assert again[0].tolist() == draws[0][0].tolist()


def test_a_part_id_range_below_the_part_count_names_the_key():
    enc = GraphEncoding(part_id_range=2)
    with pytest.raises(UserError, match=r"model\.graph\.part_id_range=2: .*at least 3"):
        node_ids(PART_OF_SURFACE, SURFACE_INDEX, 3, enc, True, np.random.default_rng(0))
