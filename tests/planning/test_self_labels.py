"""Self-training's labels (grace/planning/self_labels.py): only the plan's orders that the
simulator accepted at every step become targets, and everything the label's DAG holds is made
of accepted steps; an infeasibility proof labels the empty state; a search without either gives
no label."""

import itertools

import numpy as np
import pytest
from grace_tests_conftest import accepted, fake_plan
from hydra.utils import instantiate
from planning_fakes import MaskSteps, TableScorer, fixed_scores, line_assembly, random_world

from grace.domain.assembly import full_mask
from grace.planning.fixation_prior import FixationPrior
from grace.planning.search import Direction, VerifiedSearch
from grace.planning.self_labels import (
    own_sequence,
    plan_labels,
    probe_steps,
    search_negatives,
    verified_orders,
)
from grace.planning.step_checks import brute_force


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


def searched_worlds(k: int = 2):
    """Feasible random 7-part worlds searched for `k` orders in both directions: (brute force,
    the search's result, its plan, its negatives, the world's checks and exact prior)."""
    for seed, direction in itertools.product(range(30), Direction):
        masks, touch = random_world(7, np.random.default_rng(seed))
        truth = brute_force(MaskSteps(masks, touch))
        if not truth.feasible:
            continue
        prior = FixationPrior.of_steps(MaskSteps(masks, touch))
        table = np.random.default_rng(seed).random((128, 7))
        result = VerifiedSearch(k=k, direction=direction).search(
            lambda s, t=table: t[s], MaskSteps(masks, touch), prior.allows, prior_proves=True
        )
        world = MaskSteps(masks, touch)
        plan = fake_plan(
            line_assembly(7),
            lambda s, p, w=world: w.check(s, p).feasible,
            [r.sequence for r in result.orders],
        )
        yield truth, result, plan, search_negatives(result, prior), world, prior


def test_the_mask_keeps_only_labels_the_brute_force_agrees_with():
    """With the search's negatives, every part a state's label covers has the brute force's
    label there; the parts it leaves out include valid ones the partial label calls invalid."""
    hidden = covered = 0
    for truth, _, plan, negatives, _, _ in searched_worlds():
        sample = plan_labels(plan, line_assembly(7), negatives)
        assert set(sample.known) == set(sample.truth.states.tolist())
        for state, known in sample.known.items():
            if state == full_mask(7):
                continue
            assert known & state == state  # placed parts: known to be no next step
            expected = truth.label(state)
            assert sample.truth.label(state) & known == expected & known
            hidden += (expected & ~known & ~sample.truth.label(state)).bit_count()
            covered += (known & ~state).bit_count()
        assert 0 < sample.info["known_share"] <= 1
    assert hidden > 0 and covered > 0


def test_the_searchs_negatives_are_its_refusals_and_the_steps_fixation_refuses():
    masks, touch = random_world(7, np.random.default_rng(3))
    prior = FixationPrior.of_steps(MaskSteps(masks, touch))
    result = VerifiedSearch(k=1).search(
        fixed_scores({}, 7), MaskSteps(masks, touch), prior.allows, prior_proves=True
    )
    negatives = search_negatives(result, prior)
    refused = [e for e in result.events if e.kind == "refused"]
    assert refused and all(negatives(e.state) >> e.part & 1 for e in refused)
    barred = [(s, p) for s in range(128) for p in range(7) if not s >> p & 1]
    barred = [(s, p) for s, p in barred if not prior.allows(s, p)]
    assert barred and all(negatives(s) >> p & 1 for s, p in barred)
    assert all(negatives(s) & s == 0 for s in range(128))


@pytest.mark.parametrize("budget", [10**6, 2])
def test_the_probe_decides_the_steps_the_search_left_unknown_as_the_brute_force_does(budget):
    """`probe_steps` labels a step out of a verified order's state valid only if a completion
    exists, and a dead end only if none does (a placeable step into a state whose every label
    is 0, as the brute force has it); with an unlimited budget it decides every step of those
    states, with a small one it leaves some open but is never wrong."""
    decided = left_open = dead_states = 0
    for truth, _, plan, negatives, world, prior in searched_worlds():
        orders = verified_orders(plan)
        probed = probe_steps(orders, negatives, world, prior, budget)
        sample = plan_labels(plan, line_assembly(7), negatives, probed)
        assert all(o in set(truth.orders()) for o in probed.orders)
        placeable = dict(zip(truth.states.tolist(), truth.placeable.tolist(), strict=True))
        mine = zip(sample.truth.states.tolist(), sample.truth.placeable.tolist(), strict=True)
        for state, steps in mine:
            known = sample.known[state]
            assert sample.truth.label(state) & known == truth.label(state) & known
            assert steps & placeable[state] == steps  # every step in the label is placeable
            dead_states += not sample.truth.label(state) and state != full_mask(7)
        full = full_mask(7)
        before = plan_labels(plan, line_assembly(7), negatives)
        for state, known in before.known.items():
            if state == full:
                continue
            after = sample.known[state]
            assert after & known == known
            decided += (after & ~known).bit_count()
            if budget > 100:
                assert after == full  # every step out of the orders' states is decided
        left_open += probed.open_steps
        assert sample.info["probe_checks"] == probed.checks
    assert decided > 0 and dead_states > 0
    assert (left_open > 0) == (budget < 100)


def test_the_probe_decides_the_states_on_a_path_up_to_its_first_step_not_valid():
    """With `paths`, every state a path runs through while each step is valid is decided
    whole, as the brute force has it, and so is the state where it takes its first step that
    is not valid (that step is labelled 0 and known); the paths add states the orders did not
    hold."""
    added = broken = 0
    for seed, (truth, _, plan, negatives, world, prior) in enumerate(searched_worlds(k=1)):
        orders = verified_orders(plan)
        rng = np.random.default_rng(seed)
        valid = max(truth.orders())  # the brute force's last order, rarely the search's
        paths = [valid, tuple(rng.permutation(7).tolist()), (*valid[:3], *valid[:2:-1])]
        probed = probe_steps(orders, negatives, world, prior, 10**6, paths)
        sample = plan_labels(plan, line_assembly(7), negatives, probed)
        alone = probe_steps(orders, negatives, world, prior, 10**6)
        before = plan_labels(plan, line_assembly(7), negatives, alone).known
        for path in paths:
            state = 0
            for part in path:
                assert sample.known[state] == full_mask(7)
                assert sample.truth.label(state) == truth.label(state)
                added += before.get(state) != full_mask(7)
                if not truth.label(state) >> part & 1:
                    broken += 1
                    break
                state |= 1 << part
    assert added > 0 and broken > 0


def test_own_sequence_is_the_top_sequence_past_lambda_else_the_greedy_path():
    scorer = TableScorer(5, seed=4)
    scorer.table[:] = 0.6
    for state in range(32):  # part 4 first, then ascending: the one sequence past λ = 0.5
        scorer.table[state, 4] = 0.9
    scorer.table[0, :4] = 0.1
    assert own_sequence(scorer, line_assembly(5), 0.5) == (4, 0, 1, 2, 3)
    scorer.table[0b10000, 1] = 0.7
    assert own_sequence(scorer, line_assembly(5), 0.5) == (4, 1, 0, 2, 3)
    scorer.table[0b10000] = [0.3, 0.4, 0.2, 0.1, 0.0]  # nothing passes λ after part 4
    assert own_sequence(scorer, line_assembly(5), 0.5) == (4, 1, 0, 2, 3)
