import functools

import numpy as np
import pytest
import torch
from hydra.utils import instantiate

from grace.evaluation.step_states import dead_end_steps, label_matrix
from grace.graphs.encoding import GraphEncoding
from grace.model.grace_fast import fast_logits, one_assembly_states
from grace.model.grace_pyg import NetConfig, Score
from grace.model.impls import CompiledImpl, FastImpl, PygImpl
from grace.model.module import GraceModule
from grace.model.scoring import make_scorer, part_embeddings

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)


def module(state_blocks: int = 0, pair_readout: int = 0, **graph) -> GraceModule:
    """Seeded weights, so that a test's draw does not depend on which tests ran before."""
    torch.manual_seed(0)
    net = NetConfig(state_blocks=state_blocks, pair_readout=pair_readout)
    adam = functools.partial(torch.optim.Adam, lr=1e-3)
    return GraceModule(net, GraphEncoding(**graph), FastImpl(), adam)


@pytest.mark.parametrize(("state_blocks", "pair_readout"), [(0, 0), (1, 0), (3, 0), (0, 8)])
def test_scorer_batches_states_and_matches_the_pyg_path(samples, state_blocks, pair_readout):
    """In float64: the two paths and a batch against single states are the same arithmetic in
    another order, so they agree to rounding (about 1e-13 here). In float32 they round apart by
    up to about 1e-4 (the per-state instance norm over few nearly equal parts amplifies it), and
    by how much depends on the CPU's kernels: a float32 tolerance would hold on one CPU only."""
    m = module(state_blocks, pair_readout).double()
    fast, pyg = make_scorer(m), make_scorer(m, PygImpl())
    for sample in samples[:3]:
        states = sample.truth.states
        scores = fast(sample.assembly, states)
        assert scores.shape == (len(states), sample.size)
        assert scores.min() >= 0 and scores.max() <= 1
        np.testing.assert_allclose(pyg(sample.assembly, states), scores, rtol=0, atol=1e-10)
        single = np.vstack([fast(sample.assembly, np.array([s])) for s in states])
        np.testing.assert_allclose(single, scores, rtol=0, atol=1e-10)


def test_scorer_in_float32_stays_near_float64(samples):
    """The float32 scorer, as it plans, against the same weights in float64: its rounding stays
    far below any score gap a planner acts on (0.01)."""
    exact, fast = make_scorer(module(1, 8).double()), make_scorer(module(1, 8))
    for sample in samples[:3]:
        states = sample.truth.states
        np.testing.assert_allclose(
            fast(sample.assembly, states), exact(sample.assembly, states), rtol=0, atol=1e-3
        )


@pytest.mark.parametrize("backend", ["eager", pytest.param("inductor", marks=pytest.mark.slow)])
def test_the_compiled_path_scores_as_the_fast_path(samples, backend):
    """Traced by dynamo (`eager`: the plumbing, in seconds) or compiled to C++ (`inductor`):
    one state and many, on assemblies of several sizes (dynamic shapes, no recompiling per
    size), with the default network's relational readout and max pool. In float64, where
    fused and unfused arithmetic agree to rounding on every CPU."""
    torch.manual_seed(0)
    net = NetConfig(pair_readout=8, readout_rounds=3, pool="max", placeable_head=True)
    adam = functools.partial(torch.optim.Adam, lr=1e-3)
    m = GraceModule(net, GraphEncoding(), FastImpl(), adam).double()
    fast, compiled = make_scorer(m), make_scorer(m, CompiledImpl(backend))
    for sample in samples[:4]:
        states = sample.truth.states
        for query in (states[:1], states[-2:-1], states):
            np.testing.assert_allclose(
                compiled(sample.assembly, query), fast(sample.assembly, query), rtol=0, atol=1e-10
            )


def test_part_embeddings_shape(samples):
    emb = part_embeddings(module(), samples[0].assembly)
    assert emb.shape == (samples[0].size, 94) and np.isfinite(emb).all()


@pytest.mark.parametrize("graph", [{"pe": "random"}, {"permute_parts": "test"}])
def test_randomised_test_encoding_is_repeatable(samples, graph):
    m = module(**graph)
    sample = samples[3]
    a = make_scorer(m)(sample.assembly, sample.truth.states)
    b = make_scorer(m)(sample.assembly, sample.truth.states)
    np.testing.assert_array_equal(a, b)
    plain = module()
    plain.load_state_dict(m.state_dict())
    assert not np.allclose(make_scorer(plain)(sample.assembly, sample.truth.states), a)


@pytest.mark.parametrize("rule", list(Score))
def test_the_planner_takes_no_dead_end_step_its_next_step_output_keeps_below_lambda(
    cfg_factory, samples, rule
):
    """The documented property of the default score (docs/training.md), on the feasible steps
    into dead ends from the true orders' states of assemblies the model never saw: the planner's
    score never exceeds the next-step output, so a step that output scores at its dead-end
    target (0.4) stays below λ = 0.5, however sure the physical output is (here made sure by
    its bias). The geometric mean breaks it: 0.4 becomes sqrt(0.4 · 0.98) ≈ 0.63."""
    torch.manual_seed(0)
    m = instantiate(cfg_factory(f"model.net.score={rule.value}").model)
    with torch.no_grad():
        m.net.head.bias[1] += 4.0  # a confident physical output
    scorer = make_scorer(m)
    excess, at_target = [], []
    for sample in samples:
        states, masks = dead_end_steps(sample.truth)
        if not states.size:  # an infeasible assembly: no true order
            continue
        steps = label_matrix(masks, sample.size)
        with torch.no_grad():
            dense = scorer._prepared(sample.assembly).dense
            logits = fast_logits(m.net, dense, *one_assembly_states(dense, states))
        step = torch.sigmoid(logits[..., 0]).numpy()
        excess.append((scorer(sample.assembly, states) - step)[steps])
        logits[..., 0] = torch.logit(torch.tensor(0.4))
        at_target.append(m.net.scores(logits).numpy()[steps])
    excess, at_target = np.concatenate(excess), np.concatenate(at_target)
    assert excess.size >= 5
    vetoes = rule is not Score.geometric
    assert (excess <= 1e-6).all() == vetoes
    assert (at_target < 0.5).all() == vetoes
