"""The precedence test refutes every order at once where the masks force a cycle, and never
refutes a world that has an order (checked against the brute force on random worlds)."""

import numpy as np
import pytest
from planning_fakes import MaskSteps, fixed_scores, random_world

from grace.planning.fixation_prior import FixationPrior
from grace.planning.precedence import refuted
from grace.planning.search import Direction, Outcome, VerifiedSearch
from grace.planning.step_checks import brute_force


def test_two_parts_blocking_each_other_for_good_are_refuted():
    # Two rails too close: whichever comes second cannot be gripped.
    assert refuted(MaskSteps([[0b010], [0b001], [0]])) in (0, 1)


def test_a_chain_of_blocks_and_needs_is_not_refuted_but_a_closed_one_is():
    # 0 before 1 (1 blocks 0's only option), 1 before 2 (2 needs 1): an order exists.
    chain = [[0b010], [0], [(0, 0b010)]]
    assert refuted(MaskSteps(chain)) is None
    # and 2 before 0 (0 blocks 2): a cycle 0 < 1 < 2 < 0 that no single check shows.
    closed = [[0b010], [0], [(0b001, 0b010)]]
    assert not brute_force(MaskSteps(closed)).feasible
    assert refuted(MaskSteps(closed)) is not None


def test_options_that_a_forced_order_rules_out_are_dropped_until_a_cycle_shows():
    # 0 before 2 (2 blocks 0), 2 before 1 (1 needs 2). Of 2's options, the one needing 1 is
    # dropped (1 comes after 2), the one left is blocked by 0: 2 before 0, a cycle that shows
    # only once the first option is gone.
    world = [[0b100], [(0, 0b100)], [0b001, (0, 0b010)]]
    assert not brute_force(MaskSteps(world)).feasible
    assert refuted(MaskSteps(world)) is not None
    assert refuted(MaskSteps([[0b100], [(0, 0b100)], [0, (0, 0b010)]])) is None


def test_fixation_with_a_single_enabler_orders_the_parts():
    world = MaskSteps([[0b010], [0], [0]])  # 0 before 1: 1 blocks 0
    # 0 may go first and 1 can follow only 0: consistent.
    assert refuted(world, FixationPrior(first=0b001, enablers=(0b010, 0b001, 0b001))) is None
    # 0 cannot go first and can follow only 1: 1 before 0, a cycle.
    stuck = FixationPrior(first=0b110, enablers=(0b010, 0b001, 0b001))
    assert refuted(world, stuck) is not None


@pytest.mark.parametrize("seed", range(40))
def test_never_refutes_a_world_that_has_an_order(seed):
    masks, touch = random_world(7, np.random.default_rng(seed))
    if refuted(MaskSteps(masks, touch)) is not None:
        assert not brute_force(MaskSteps(masks, touch)).feasible


def test_the_search_asks_no_step_check_when_the_test_refutes_the_assembly():
    rails = [[0b010], [0b001], [0]]
    for direction in Direction:
        world = MaskSteps(rails)
        result = VerifiedSearch(direction=direction).search(
            fixed_scores({}, 3), world, refute=lambda world=world: refuted(world)
        )
        assert result.outcome == Outcome.infeasible and result.exhausted
        assert result.checks == 0 and not result.orders


@pytest.mark.parametrize("seed", range(12))
def test_past_its_share_of_checks_the_brute_force_decides_an_assembly_that_small(seed):
    masks, touch = random_world(7, np.random.default_rng(seed))
    truth = brute_force(MaskSteps(masks, touch))
    scores = lambda state: np.random.default_rng(state).random(7)  # noqa: E731
    for direction in Direction:
        world = MaskSteps(masks, touch)
        search = VerifiedSearch(direction=direction, exhaustive_after=1, precedence=False)
        result = search.search(scores, world, exhaust=lambda w=world: brute_force(w))
        assert result.outcome == (Outcome.verified if truth.feasible else Outcome.infeasible)
        if not truth.feasible:  # decided after one step check per part at most, plus its own
            assert result.checks <= 7 + 1 + truth.checks
        small = VerifiedSearch(direction=direction, exhaustive_parts=6, exhaustive_after=1)
        world = MaskSteps(masks, touch)
        untouched = small.search(scores, world, exhaust=lambda: pytest.fail("7 > 6 parts"))
        assert untouched.outcome == result.outcome


def test_a_refuted_assembly_is_never_scored():
    def scores(state):
        raise AssertionError(f"state {state} scored")

    world = MaskSteps([[0b010], [0b001], [0]])
    result = VerifiedSearch().search(scores, world, refute=lambda: refuted(world))
    assert result.outcome == Outcome.infeasible and result.expanded == 1
