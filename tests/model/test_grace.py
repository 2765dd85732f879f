from types import SimpleNamespace

import numpy as np
import pytest
import torch
from torch_geometric.data import Batch

from grace.errors import UserError
from grace.graphs.assembly_graph import encode_assembly, state_flags, state_graph
from grace.graphs.cell_features import CELL_FEATURES
from grace.graphs.dense import DenseAssemblies
from grace.graphs.encoding import GraphEncoding
from grace.graphs.pair_geometry import PAIR_GEOMETRY_FEATURES
from grace.model.grace_fast import SharedWork, fast_logits, pair_readout
from grace.model.grace_pyg import GraceNet, NetConfig, Score, count_parameters

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)


def test_paper_parameter_count():
    n = count_parameters(GraceNet(NetConfig()))
    assert n == 51_701
    assert round(n / 1000, 1) == 51.7  # the paper, Sec. V-A3: 51.7 K


def test_state_blocks_variant_adds_one_surface_input():
    assert count_parameters(GraceNet(NetConfig(state_blocks=1))) == 51_701 + 2 * 94


def test_pair_readout_adds_pair_and_fuse_layers():
    p, h = 32, 94
    extra = (h * p + p) + h * p + p + ((h + 2 * p) * h + h)
    assert count_parameters(GraceNet(NetConfig(pair_readout=p))) == 51_701 + extra


def test_pair_geometry_adds_a_two_layer_mlp_to_the_readout():
    p, w = 8, 6
    base = count_parameters(GraceNet(NetConfig(pair_readout=p)))
    with_geometry = count_parameters(GraceNet(NetConfig(pair_readout=p, pair_geometry=w)))
    assert with_geometry - base == (PAIR_GEOMETRY_FEATURES * w + w) + (w * p + p)
    with pytest.raises(UserError, match=r"model\.net\.pair_geometry=4.*pair_readout"):
        NetConfig(pair_geometry=4)


def test_placeable_head_scores_both_outputs_by_the_configured_rule():
    assert count_parameters(GraceNet(NetConfig(placeable_head=True))) == 51_701 + 94 + 1
    logits = torch.tensor([[[2.0, -1.0], [0.0, 3.0]]])
    step, place = torch.sigmoid(logits[..., 0]), torch.sigmoid(logits[..., 1])
    expected = {
        Score.product: step * place,
        Score.min: torch.minimum(step, place),
        Score.geometric: torch.sqrt(step * place),
        Score.next_step: step,
    }
    for rule, scores in expected.items():
        net = GraceNet(NetConfig(placeable_head=True, score=rule.value))  # a string, as a config
        assert net.cfg.score is rule
        torch.testing.assert_close(net.scores(logits), scores)
    assert NetConfig().score is Score.min  # the default (docs/training.md)
    torch.testing.assert_close(
        GraceNet(NetConfig()).scores(logits[..., 0]), logits[..., 0].sigmoid()
    )


def _both_paths(samples, dtype, cfg=NetConfig(), enc=GraphEncoding()):  # noqa: B008
    torch.manual_seed(0)
    net = GraceNet(cfg).to(dtype)
    tensors = [encode_assembly(s.assembly, enc) for s in samples]
    states = [s.truth.states for s in samples]
    cast = lambda t: t.to(dtype) if t.is_floating_point() else t  # noqa: E731
    graphs = [state_graph(t, int(s)) for t, ss in zip(tensors, states, strict=True) for s in ss]
    ref = net(Batch.from_data_list(graphs).apply(cast))
    ref_grads = torch.autograd.grad(ref.square().sum(), list(net.parameters()))
    dense = DenseAssemblies.stack(tensors)
    for key in ("surface_x", "relation", "part_static", "pair_geometry", "ownership"):
        setattr(dense, key, cast(getattr(dense, key)))
    n = dense.part_mask.shape[1]
    index = torch.cat([torch.full((len(s),), i) for i, s in enumerate(states)])
    flags = state_flags(np.concatenate(states), n).to(dtype) * dense.part_mask[index]
    fast = fast_logits(net, dense, index, flags)[dense.part_mask[index]]
    # The GAT biases before an instance norm cancel: the fast path leaves them out (gradient 0).
    fast_grads = torch.autograd.grad(
        fast.square().sum(), list(net.parameters()), materialize_grads=True
    )
    return ref, fast, ref_grads, fast_grads


SLOW = pytest.mark.slow  # the rest of the matrix: every option value is in a fast row


@pytest.mark.parametrize(
    ("state_blocks", "pair_readout", "rounds", "geometry", "two_heads", "pool"),
    [
        (0, 0, 1, 0, False, "sum"),
        pytest.param(*(1, 0, 1, 0, False, "sum"), marks=SLOW),
        pytest.param(*(3, 0, 1, 0, False, "sum"), marks=SLOW),
        pytest.param(*(0, 8, 1, 0, False, "sum"), marks=SLOW),
        pytest.param(*(1, 8, 1, 0, False, "sum"), marks=SLOW),
        (3, 8, 1, 0, False, "sum"),
        pytest.param(*(0, 8, 3, 0, False, "sum"), marks=SLOW),
        pytest.param(*(0, 8, 3, 6, False, "sum"), marks=SLOW),
        (1, 8, 2, 6, False, "sum"),
        pytest.param(*(0, 8, 2, 6, True, "sum"), marks=SLOW),
        (0, 8, 3, 6, True, "mean"),
        pytest.param(*(1, 8, 2, 0, False, "mean"), marks=SLOW),
        (0, 8, 3, 6, True, "max"),
        (1, 8, 2, 0, False, "max"),
    ],
)
def test_fast_path_equals_pyg_path(
    samples, state_blocks, pair_readout, rounds, geometry, two_heads, pool
):
    """Same weights → same logits and parameter gradients, on a batch of mixed sizes (float64)."""
    cfg = NetConfig(
        state_blocks=state_blocks,
        pair_readout=pair_readout,
        readout_rounds=rounds,
        pair_geometry=geometry,
        placeable_head=two_heads,
        pool=pool,
    )
    ref, fast, ref_grads, fast_grads = _both_paths(samples, torch.float64, cfg)
    assert ref.shape == fast.shape
    torch.testing.assert_close(fast, ref, atol=1e-5, rtol=0)
    for g_ref, g_fast in zip(ref_grads, fast_grads, strict=True):
        torch.testing.assert_close(g_fast, g_ref, atol=1e-5, rtol=0)


@pytest.mark.parametrize(
    ("state_blocks", "pool"),
    [
        pytest.param(0, "sum", marks=SLOW),
        pytest.param(1, "sum", marks=SLOW),
        pytest.param(0, "mean", marks=SLOW),
        (0, "max"),
    ],
)
def test_one_assembly_alone_equals_pyg_path(samples, state_blocks, pool):
    """A batch of one assembly (planning, or one large assembly's chunk in training) takes the
    unpadded route (plain instance norms, pair features broadcast over its states): same logits
    and gradients as the PyG path, for every sample, also the 3-part one."""
    cfg = NetConfig(
        state_blocks=state_blocks,
        pair_readout=8,
        readout_rounds=3,
        pair_geometry=6,
        placeable_head=True,
        pool=pool,
    )
    for sample in samples:
        ref, fast, ref_grads, fast_grads = _both_paths([sample], torch.float64, cfg)
        torch.testing.assert_close(fast, ref, atol=1e-5, rtol=0)
        for g_ref, g_fast in zip(ref_grads, fast_grads, strict=True):
            torch.testing.assert_close(g_fast, g_ref, atol=1e-5, rtol=0)


def test_fast_path_matches_in_float32(samples):
    """In float32 both paths round differently, and the per-state InstanceNorm over few nearly
    equal parts amplifies that: gradients agree to 1e-3 of the largest gradient (the PyG path's
    own float32 error against float64 is of the same order)."""
    ref, fast, ref_grads, fast_grads = _both_paths(samples, torch.float32)
    torch.testing.assert_close(fast, ref, atol=1e-3, rtol=0)
    scale = max(float(g.abs().max()) for g in ref_grads)
    for g_ref, g_fast in zip(ref_grads, fast_grads, strict=True):
        torch.testing.assert_close(g_fast, g_ref, atol=1e-3 * scale, rtol=0)


def test_state_blocks_must_fit_the_surface_blocks():
    with pytest.raises(UserError, match=r"model\.net\.state_blocks=4"):
        NetConfig(state_blocks=4)


def test_readout_rounds_need_a_pair_readout():
    with pytest.raises(UserError, match=r"model\.net\.readout_rounds=2"):
        NetConfig(readout_rounds=2)


def _readout_of_part_zero(pool: str, copies: int) -> torch.Tensor:
    """Part 0's fused features when each of its three other parts (two placed) stands
    `copies` times, every copy with the same pair features towards part 0."""
    torch.manual_seed(0)
    net = GraceNet(NetConfig(hidden=6, pair_readout=4, pool=pool)).double()
    towards_zero = torch.randn(3, 4, dtype=torch.float64)
    n = 1 + 3 * copies
    relations = torch.zeros(1, n, n, 4, dtype=torch.float64)
    relations[0, 1:, 0] = towards_zero.repeat(copies, 1)
    flags = torch.tensor([[0.0] + [1.0, 1.0, 0.0] * copies], dtype=torch.float64)
    shared = SharedWork(None, None, None, relations, relations.sum(dim=1))
    dense = SimpleNamespace(part_mask=torch.ones(1, n, dtype=torch.bool))
    h = torch.zeros(1, n, 6, dtype=torch.float64)
    return pair_readout(net, shared, dense, torch.zeros(1, dtype=torch.long), flags, h)[0, 0]


@pytest.mark.parametrize("pool", ["mean", "max"])
def test_a_size_free_pool_keeps_its_value_when_the_same_pairs_repeat(pool):
    """The property that makes `pool=mean|max` carry to larger assemblies: three times the same
    neighbours (same pair features, same placed share) read as once; a sum does not."""
    torch.testing.assert_close(_readout_of_part_zero(pool, 3), _readout_of_part_zero(pool, 1))
    assert not torch.allclose(_readout_of_part_zero("sum", 3), _readout_of_part_zero("sum", 1))


def test_cell_features_take_both_paths_alike(samples, default_cell):
    """The oracle's part inputs (model.graph.cell) widen the part conv's input alike on both
    paths: same logits and gradients (float64), on a batch of two sizes."""
    enc = GraphEncoding(cell=default_cell)
    cfg = NetConfig(pair_readout=8, pair_geometry=6, extra_part_features=CELL_FEATURES)
    ref, fast, ref_grads, fast_grads = _both_paths(samples[:2], torch.float64, cfg, enc)
    torch.testing.assert_close(fast, ref, atol=1e-5, rtol=0)
    for g_ref, g_fast in zip(ref_grads, fast_grads, strict=True):
        torch.testing.assert_close(g_fast, g_ref, atol=1e-5, rtol=0)
