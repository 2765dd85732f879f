import numpy as np
import pytest
from hydra.utils import instantiate

from grace.domain.assembly import full_mask
from grace.graphs.datamodule import StateDataModule, training_states
from grace.graphs.encoding import GraphEncoding
from grace.planning.visited import visited_states


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


def test_a_planner_that_passes_everything_visits_every_state(samples):
    def accept_all(assembly, states):
        return np.ones((len(states), assembly.n_parts))

    extra = visited_states(accept_all, samples, 0.5, "orders")
    for i, sample in enumerate(samples):
        every = set(range(full_mask(sample.size)))  # all non-complete states
        expected = sorted(every - set(training_states(sample, "orders")[0].tolist()))
        states, labels = extra[i]
        assert states.tolist() == expected
        assert labels.tolist() == [_brute_force_label(sample.truth, s) for s in expected]
    assert any(s.truth.feasible for s in samples) and not all(
        len(s.truth.states) == 2**s.size for s in samples
    )  # the case has unreachable states, labelled 0


def test_a_planner_that_never_passes_visits_only_the_empty_state(samples):
    def reject_all(assembly, states):
        return np.zeros((len(states), assembly.n_parts))

    extra = visited_states(reject_all, samples, 0.5, "reachable")
    assert extra == {}  # the empty state is a training state already


def test_extra_states_join_the_training_batches(samples):
    def accept_all(assembly, states):
        return np.ones((len(states), assembly.n_parts))

    dm = StateDataModule(
        samples, [], GraphEncoding(), states="orders", batch_size=8, balance_steps=True
    )
    extra = visited_states(accept_all, samples, 0.5, "orders")
    dm.train_set.extend(extra, dm.chunk_size)
    batches = list(dm.train_dataloader())
    assert sum(b.n_states for b in batches) == sum(2**s.size - 1 for s in samples)
    assert sum(len(b.weights) for b in batches) == sum(2**s.size - 1 for s in samples)
