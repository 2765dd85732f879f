import numpy as np
import pytest
import torch
from hydra.errors import ConfigCompositionException, InstantiationException
from hydra.utils import instantiate

from grace.domain.assembly import full_mask
from grace.graphs.datamodule import (
    AssemblyBatchSampler,
    StateDataModule,
    collate_dense,
    collate_graphs,
    step_weights,
    training_states,
)
from grace.graphs.dense import DenseAssemblies
from grace.graphs.encoding import GraphEncoding

CONFIG_ERRORS = (ConfigCompositionException, InstantiationException)
"""A bad value fails at composition (a type) or at instantiation (a range)."""


@pytest.fixture
def samples(fake_simulator):
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(1)
    return [simulator.sample(n, rng) for n in (3, 4, 5, 6, 5, 4, 6, 6)]


def test_state_sets(samples):
    infeasible = [s for s in samples if not s.truth.feasible]
    feasible = [s for s in samples if s.truth.feasible]
    assert infeasible and feasible
    for sample in samples:
        states, labels = training_states(sample, "reachable")
        assert full_mask(sample.size) not in states.tolist()
        assert len(states) == len(sample.truth.states) - int(sample.truth.feasible)
        on_orders, order_labels = training_states(sample, "orders")
        assert set(on_orders) <= set(states)
        assert order_labels.tolist() == [sample.truth.label(int(s)) for s in on_orders]
        if sample.truth.feasible:
            assert np.all(order_labels != 0)
    # infeasible assemblies contribute states with zero labels: all reachable ones, or the empty
    states, labels = training_states(infeasible[0], "reachable")
    assert len(states) > 0 and not labels.any()
    states, labels = training_states(infeasible[0], "orders")
    assert states.tolist() == [0] and labels.tolist() == [0]
    with pytest.raises(ValueError, match="'all' is not a valid StateSet"):
        training_states(samples[0], "all")


def test_the_config_checks_sampling_options(cfg_factory):
    for key, value in (("states", "all"), ("mixing", "random"), ("batch_size", "many")):
        with pytest.raises(CONFIG_ERRORS, match=rf"datamodule\.{key}"):
            cfg_factory(f"datamodule.{key}={value}")


def test_sampler_packs_every_chunk_once_and_reshuffles():
    sizes = [5, 100, 30, 256, 7, 80, 120]
    sampler = AssemblyBatchSampler(sizes, 128, shuffle=True, seed=0)
    first, second = list(sampler), list(sampler)
    for batches in (first, second):
        assert sorted(i for b in batches for i in b) == list(range(len(sizes)))
        assert all(sum(sizes[i] for i in b[:-1]) < 128 for b in batches)
    assert first != second


@pytest.mark.parametrize("collate", [collate_dense, collate_graphs])
def test_loaders_cover_all_states_with_padding_masks(samples, collate):
    dm = StateDataModule(samples[:5], samples[5:], GraphEncoding(), collate, batch_size=16)
    total = 0
    for batch in dm.train_dataloader():
        total += batch.n_states
        sizes = batch.mask.sum(dim=1)
        assert torch.all(batch.flags[~batch.mask] == 0) and torch.all(
            batch.labels[~batch.mask] == 0
        )
        assert torch.all(batch.flags.sum(dim=1) < sizes)  # the full state is never a sample
        if collate is collate_dense:
            assert isinstance(batch.inputs, DenseAssemblies)
        else:
            assert batch.inputs["part"].num_nodes == int(sizes.sum())
    assert total == sum(len(training_states(s, "reachable")[0]) for s in samples[:5])


def test_state_mixing_draws_states_across_assemblies(samples):
    dm = StateDataModule(samples, [], GraphEncoding(), batch_size=8, mixing="state")
    batches = list(dm.train_dataloader())
    assert sum(b.n_states for b in batches) == sum(
        len(training_states(s, "reachable")[0]) for s in samples
    )
    assert max(len(b.inputs.part_mask) for b in batches) > 2  # several assemblies per batch


def test_step_balancing_gives_every_step_of_a_size_the_same_weight(samples):
    states = [training_states(s, "reachable")[0] for s in samples]
    weights = step_weights(samples, states)
    for size in {s.size for s in samples}:
        picked = [i for i, s in enumerate(samples) if s.size == size]
        steps = np.concatenate([[bin(int(x)).count("1") for x in states[i]] for i in picked])
        w = np.concatenate([weights[i] for i in picked])
        assert np.isclose(w.mean(), 1.0)
        totals = [w[steps == t].sum() for t in np.unique(steps)]
        assert np.allclose(totals, len(w) / len(totals))
        empty = [weights[i][list(states[i]).index(0)] for i in picked]
        assert min(empty) > 1.0  # one empty state per assembly: the rarest step weighs most


def test_balanced_loader_carries_weights_and_validation_does_not(samples):
    dm = StateDataModule(
        samples[:5], samples[5:], GraphEncoding(), batch_size=16, balance_steps=True
    )
    train = list(dm.train_dataloader())
    assert all(b.weights is not None and len(b.weights) == b.n_states for b in train)
    weights = torch.cat([b.weights for b in train])
    assert np.isclose(float(weights.sum()), len(weights), rtol=1e-4)  # mean 1 per size
    assert float(weights.max()) > 1.0 > float(weights.min())
    assert all(b.weights is None for b in dm.val_dataloader())
