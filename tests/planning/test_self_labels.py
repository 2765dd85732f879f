"""Self-training's labels (grace/planning/self_labels.py): only the plan's orders that the
simulator accepted at every step become targets, and everything the label's DAG holds is made
of accepted steps; an infeasibility proof labels the empty state; a search without either gives
no label."""

import itertools

import numpy as np
import pytest
from grace_tests_conftest import accepted, fake_plan
from hydra.utils import instantiate

from grace.planning.self_labels import plan_labels, verified_orders


def row_world(fake_simulator, n: int, seed: int):
    """A FakeSimulator row and its robot rules (conftest.py)."""
    sim = instantiate(fake_simulator)
    assembly = sim.generate(n, np.random.default_rng(seed))
    return assembly, sim._rules(assembly, robot=True)


@pytest.mark.parametrize("seed", range(6))
def test_labels_hold_only_orders_made_of_accepted_steps(fake_simulator, seed):
    assembly, can_place = row_world(fake_simulator, 5, seed)
    rng = np.random.default_rng(seed)
    good = [o for o in itertools.permutations(range(5)) if accepted(can_place, o)]
    picked = rng.permutation(len(good))[:3].tolist() if good else []
    orders = [good[i] for i in picked] + [tuple(rng.permutation(5).tolist()) for _ in range(9)]
    plan = fake_plan(assembly, can_place, orders)
    kept = verified_orders(plan)
    assert kept == [o for o in orders if accepted(can_place, o)]
    sample = plan_labels(plan, assembly)
    if not good:
        assert sample is None
        return
    labelled = list(sample.truth.orders())
    # the DAG joins orders that meet in a state: every step of every order is still one the
    # simulator accepted in that very state
    assert set(kept) <= set(labelled)
    assert all(accepted(can_place, o) for o in labelled)
    assert sample.info["labels"] == "verified" and sample.info["verified_orders"] == len(kept)


def test_valid_parts_are_those_starting_a_verified_continuation(fake_simulator):
    assembly, can_place = row_world(fake_simulator, 4, 0)
    good = [o for o in itertools.permutations(range(4)) if accepted(can_place, o)]
    assert len(good) >= 2
    sample = plan_labels(fake_plan(assembly, can_place, good[:2]), assembly)
    first = {o[0] for o in good[:2]}
    assert sample.truth.label(0) == sum(1 << p for p in first)
    # a state off the verified orders has no label
    off = next(1 << p for p in range(4) if p not in first)
    with pytest.raises(KeyError):
        sample.truth.label(off)


def test_a_proof_of_infeasibility_labels_the_empty_state_and_a_budget_gives_none(
    fake_simulator,
):
    assembly, can_place = row_world(fake_simulator, 4, 1)
    proved = plan_labels(fake_plan(assembly, can_place, [], "infeasible"), assembly)
    assert not proved.truth.feasible and proved.truth.order_states().tolist() == [0]
    assert (
        plan_labels(fake_plan(assembly, can_place, [], "not found within budget"), assembly) is None
    )
