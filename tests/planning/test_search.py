"""Verified search on hand-written worlds (fake step checks and fake policies).

Every order it returns passes every step check, a wrong policy costs checks but never
correctness, budgets stop it with "not found within budget", and the exhaustive mode finds
exactly the brute force's orders."""

import itertools

import numpy as np
import pytest
from planning_fakes import MaskSteps, fixed_scores

from grace.planning.search import Frontier, Outcome, VerifiedSearch
from grace.planning.step_checks import brute_force, hitting_set, minimal_masks

LINE = [0b0010, 0b0101, 0b1010, 0b0100]
"""Four parts in a row: a later part must touch a placed one (fixation)."""

LATE_BLOCK = [[0], [0], [0], [0b0010]]
"""Part 3 is blocked for good once part 1 is placed: 3 must come before 1."""


def orders_of(world: MaskSteps) -> set[tuple[int, ...]]:
    return set(brute_force(world).orders())


def steps_pass(world: MaskSteps, order) -> bool:
    state = 0
    for part in order:
        if not world.check(state, part).feasible:
            return False
        state |= 1 << part
    return True


@pytest.mark.parametrize("frontier", list(Frontier))
@pytest.mark.parametrize("learn", [True, False])
def test_a_policy_wrong_at_step_1_still_gets_a_verified_order(frontier, learn):
    known = orders_of(MaskSteps(LATE_BLOCK, LINE))
    assert known == {(2, 3, 1, 0), (3, 2, 1, 0)}  # the world this test relies on
    # The policy's favourite first step, part 1, is possible but leads nowhere (3 must precede
    # 1); it also likes part 0 everywhere, which fixation refuses until part 1 is placed.
    wrong = fixed_scores({0: [0.8, 0.99, 0.1, 0.1]}, 4, default=0.5)
    world = MaskSteps(LATE_BLOCK, LINE)
    result = VerifiedSearch(frontier=frontier, learn_blocks=learn).search(wrong, world)
    assert result.outcome == Outcome.verified
    assert result.orders[0].sequence in known
    assert steps_pass(MaskSteps(LATE_BLOCK, LINE), result.orders[0].sequence)
    assert result.first_checks == result.checks == world.checks
    assert any(e.kind == "refused" and e.part == 3 for e in result.events)
    # a policy right at every step needs one check per part
    right = fixed_scores({0: [0, 0, 0.1, 0.9], 0b1000: [0, 0, 0.9, 0], 0b1100: [0, 0.9, 0, 0]}, 4)
    direct = VerifiedSearch(frontier=frontier, learn_blocks=learn).search(
        right, MaskSteps(LATE_BLOCK, LINE)
    )
    assert direct.orders[0].sequence == (3, 2, 1, 0) and direct.checks == 4


def test_learnt_blocks_rule_out_states_without_checking_them():
    """Once part 3 is refused with part 1 as its blocker, every state holding 1 but not 3 is
    dead: the search jumps back to the empty state instead of trying the rest below part 1."""
    wrong = fixed_scores({0: [0.8, 0.99, 0.1, 0.1]}, 4, default=0.5)
    learnt = VerifiedSearch(learn_blocks=True).search(wrong, MaskSteps(LATE_BLOCK, LINE))
    plain_world = MaskSteps(LATE_BLOCK, LINE)
    plain = VerifiedSearch(learn_blocks=False).search(
        fixed_scores({0: [0.8, 0.99, 0.1, 0.1]}, 4, default=0.5), plain_world
    )
    assert learnt.checks < plain.checks
    assert learnt.orders[0].sequence == plain.orders[0].sequence


@pytest.mark.parametrize("frontier", list(Frontier))
def test_a_budget_below_the_need_says_so_and_returns_no_order(frontier):
    wrong = fixed_scores({0: [0.8, 0.99, 0.1, 0.1]}, 4, default=0.5)
    needed = VerifiedSearch(frontier=frontier).search(wrong, MaskSteps(LATE_BLOCK, LINE)).checks
    for budget in range(needed):
        world = MaskSteps(LATE_BLOCK, LINE)
        scores = fixed_scores({0: [0.8, 0.99, 0.1, 0.1]}, 4, default=0.5)
        result = VerifiedSearch(frontier=frontier, max_checks=budget).search(scores, world)
        assert result.outcome == Outcome.budget and not result.orders
        assert result.checks == world.checks <= budget
    assert VerifiedSearch(max_seconds=0.0).search(wrong, MaskSteps(LATE_BLOCK, LINE)).outcome == (
        Outcome.budget
    )


def test_an_infeasible_world_is_reported_infeasible_like_the_brute_force():
    # Two rails too close: whichever comes second cannot be gripped (each blocks the other).
    rails = [[0b010], [0b001], [0]]
    assert not brute_force(MaskSteps(rails)).feasible
    for frontier, learn in itertools.product(Frontier, (True, False)):
        world = MaskSteps(rails)
        result = VerifiedSearch(frontier=frontier, learn_blocks=learn).search(
            fixed_scores({}, 3), world
        )
        assert result.outcome == Outcome.infeasible and not result.orders
        assert result.exhausted and result.first_checks is None
        assert result.checks <= brute_force(MaskSteps(rails)).checks


def test_a_part_no_option_of_which_is_usable_refutes_the_assembly_in_one_check():
    world = MaskSteps([[0], [], [0]])  # part 1 can never be placed
    result = VerifiedSearch().search(fixed_scores({0: [0.1, 0.9, 0.1]}, 3), world)
    assert result.outcome == Outcome.infeasible and result.checks == 1


def random_world(n: int, rng: np.random.Generator) -> tuple[list[list[int]], list[int]]:
    """Random blocker masks (0–3 options per part, each blocked by 0–2 others) and a random
    connected contact graph."""
    touch = [0] * n
    for p in range(1, n):
        q = int(rng.integers(p))
        touch[p] |= 1 << q
        touch[q] |= 1 << p
    masks = []
    for p in range(n):
        options = []
        for _ in range(int(rng.integers(0, 4))):
            others = [q for q in range(n) if q != p]
            chosen = rng.choice(others, size=int(rng.integers(0, 3)), replace=False)
            options.append(sum(1 << int(q) for q in chosen))
        masks.append(options)
    return masks, touch


@pytest.mark.parametrize("seed", range(12))
def test_exhaustive_mode_verifies_exactly_the_brute_force_orders(seed):
    rng = np.random.default_rng(seed)
    masks, touch = random_world(6, rng)
    truth = brute_force(MaskSteps(masks, touch))
    for frontier, learn in itertools.product(Frontier, (True, False)):
        table = rng.random((64, 6))
        world = MaskSteps(masks, touch)
        result = VerifiedSearch(k=None, frontier=frontier, learn_blocks=learn).search(
            lambda s, table=table: table[s], world
        )
        assert set(result.verified.orders()) == set(truth.orders())
        assert {r.sequence for r in result.orders} == set(truth.orders())
        assert result.outcome == (Outcome.verified if truth.feasible else Outcome.infeasible)
        assert result.checks <= truth.checks  # each (state, part) at most once
        probabilities = [r.probability for r in result.orders]
        assert probabilities == sorted(probabilities, reverse=True)
        # first-order searches: verified, passing every step, or infeasible exactly when it is
        first = VerifiedSearch(frontier=frontier, learn_blocks=learn).search(
            lambda s, table=table: table[s], MaskSteps(masks, touch)
        )
        assert first.outcome == result.outcome
        assert all(steps_pass(MaskSteps(masks, touch), r.sequence) for r in first.orders)


def test_k_orders_come_best_first_and_distinct():
    masks, touch = [[0]] * 5, [0b11111 ^ (1 << p) for p in range(5)]  # every order works
    table = np.random.default_rng(3).random((32, 5))
    result = VerifiedSearch(k=4).search(lambda s: table[s], MaskSteps(masks, touch))
    orders = [r.sequence for r in result.orders]
    assert len(orders) == 4 == len(set(orders))
    for r in result.orders:  # each probability is the product of its step scores
        state, steps = 0, []
        for part in r.sequence:
            steps.append(table[state][part])
            state |= 1 << part
        assert r.step_scores == pytest.approx(steps) and r.probability == pytest.approx(
            np.prod(steps)
        )
    assert [r.probability for r in result.orders] == sorted(
        (r.probability for r in result.orders), reverse=True
    )


def test_hitting_sets_and_minimal_masks():
    assert minimal_masks([0b110, 0b010, 0b010, 0b101]) == [0b010, 0b101]
    blocking = hitting_set([0b0110, 0b0011, 0b1010], 0b1111)
    assert all(m & blocking for m in (0b0110, 0b0011, 0b1010))
    assert blocking == 0b0010  # one part meets all three
    assert hitting_set([], 0b1) == 0
