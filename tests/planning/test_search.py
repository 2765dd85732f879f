"""Verified search on hand-written worlds (fake step checks and fake policies).

Every order it returns passes every step check, a wrong policy costs checks but never
correctness, budgets stop it with "not found within budget", and the exhaustive mode finds
exactly the brute force's orders, in both directions."""

import itertools

import numpy as np
import pytest
from planning_fakes import MaskSteps, fixed_scores, line_assembly, random_world

from grace.planning.fixation_prior import FixationPrior
from grace.planning.search import Direction, Frontier, Outcome, VerifiedSearch
from grace.planning.step_checks import (
    StepCheck,
    accepted_throughout,
    blocking_set,
    brute_force,
    minimal_masks,
)

LINE = [0b0010, 0b0101, 0b1010, 0b0100]
"""Four parts in a row: a later part must touch a placed one (fixation)."""

LATE_BLOCK = [[0], [0], [0], [0b0010]]
"""Part 3 is blocked for good once part 1 is placed: 3 must come before 1."""

FULL = 0b1111

WRONG = {
    # Forward, the favourite first step, part 1, is possible but leads nowhere (3 must precede
    # 1), and part 0, which fixation refuses until part 1 is placed, comes next.
    Direction.forward: {0: [0.8, 0.99, 0.1, 0.1]},
    # Backward, the favourite last part, 3, cannot go last (1 blocks it), and the next one, 1,
    # can, but leaves {0, 2, 3}, which no order builds (fixation).
    Direction.backward: {FULL: [0.1, 0.9, 0.2, 0.99]},
}
"""Policies wrong at their first decision, per direction."""

RIGHT = {
    Direction.forward: {0: [0, 0, 0.1, 0.9], 0b1000: [0, 0, 0.9, 0], 0b1100: [0, 0.9, 0, 0]},
    Direction.backward: {FULL: [0.9, 0, 0, 0], 0b1110: [0, 0.9, 0, 0], 0b1100: [0, 0, 0.9, 0.1]},
}
"""Policies right at every decision: the order 3 2 1 0."""


def orders_of(world: MaskSteps) -> set[tuple[int, ...]]:
    return set(brute_force(world).orders())


@pytest.mark.parametrize("direction", list(Direction))
@pytest.mark.parametrize("frontier", list(Frontier))
@pytest.mark.parametrize("learn", [True, False])
def test_a_policy_wrong_at_its_first_decision_still_gets_a_verified_order(
    direction, frontier, learn
):
    known = orders_of(MaskSteps(LATE_BLOCK, LINE))
    assert known == {(2, 3, 1, 0), (3, 2, 1, 0)}  # the world this test relies on
    search = VerifiedSearch(direction=direction, frontier=frontier, learn_blocks=learn)
    world = MaskSteps(LATE_BLOCK, LINE)
    result = search.search(fixed_scores(WRONG[direction], 4), world)
    assert result.outcome == Outcome.verified
    assert result.orders[0].sequence in known
    assert accepted_throughout(result.orders[0].sequence, MaskSteps(LATE_BLOCK, LINE))
    assert result.first_checks == result.checks == world.checks
    assert any(e.kind == "refused" and e.part == 3 for e in result.events)
    direct = search.search(fixed_scores(RIGHT[direction], 4), MaskSteps(LATE_BLOCK, LINE))
    assert direct.orders[0].sequence == (3, 2, 1, 0) and direct.checks == 4  # one per part


def test_forward_learnt_blocks_rule_out_states_without_checking_them():
    """Once part 3 is refused with part 1 as its blocker, every state holding 1 but not 3 is
    dead: the search jumps back to the empty state instead of trying the rest below part 1."""
    search = VerifiedSearch(direction=Direction.forward)
    learnt = search.search(fixed_scores(WRONG[Direction.forward], 4), MaskSteps(LATE_BLOCK, LINE))
    plain = VerifiedSearch(direction=Direction.forward, learn_blocks=False).search(
        fixed_scores(WRONG[Direction.forward], 4), MaskSteps(LATE_BLOCK, LINE)
    )
    assert learnt.checks < plain.checks
    assert learnt.orders[0].sequence == plain.orders[0].sequence


def test_backward_learnt_blocks_skip_steps_known_to_be_refused():
    """Backward, part 3 refused with part 1 placed is refused wherever 1 still is: the search
    does not ask again until 1 has been taken away."""
    rows = {FULL: [0.1, 0.2, 0.3, 0.9], 0b1110: [0, 0.2, 0.3, 0.9]}
    result = VerifiedSearch().search(fixed_scores(rows, 4), MaskSteps(LATE_BLOCK, LINE))
    skipped = [e for e in result.events if e.kind == "ruled_out"]
    assert skipped and all(e.part == 3 and e.blocked_by == 0b0010 for e in skipped)
    assert result.orders[0].sequence in orders_of(MaskSteps(LATE_BLOCK, LINE))


@pytest.mark.parametrize("direction", list(Direction))
@pytest.mark.parametrize("frontier", list(Frontier))
def test_a_budget_below_the_need_says_so_and_returns_no_order(direction, frontier):
    search = VerifiedSearch(direction=direction, frontier=frontier)
    wrong = WRONG[direction]
    needed = search.search(fixed_scores(wrong, 4), MaskSteps(LATE_BLOCK, LINE)).checks
    for budget in range(needed):
        world = MaskSteps(LATE_BLOCK, LINE)
        result = VerifiedSearch(direction=direction, frontier=frontier, max_checks=budget).search(
            fixed_scores(wrong, 4), world
        )
        assert result.outcome == Outcome.budget and not result.orders
        assert result.checks == world.checks <= budget
    timed_out = VerifiedSearch(direction=direction, max_seconds=0.0).search(
        fixed_scores(wrong, 4), MaskSteps(LATE_BLOCK, LINE)
    )
    assert timed_out.outcome == Outcome.budget


@pytest.mark.parametrize("direction", list(Direction))
def test_an_infeasible_world_is_reported_infeasible_like_the_brute_force(direction):
    # Two rails too close: whichever comes second cannot be gripped (each blocks the other).
    rails = [[0b010], [0b001], [0]]
    assert not brute_force(MaskSteps(rails)).feasible
    for frontier, learn in itertools.product(Frontier, (True, False)):
        world = MaskSteps(rails)
        search = VerifiedSearch(direction=direction, frontier=frontier, learn_blocks=learn)
        result = search.search(fixed_scores({}, 3), world)
        assert result.outcome == Outcome.infeasible and not result.orders
        assert result.exhausted and result.first_checks is None
        if direction == Direction.forward:
            assert result.checks <= brute_force(MaskSteps(rails)).checks


@pytest.mark.parametrize("direction", list(Direction))
def test_a_part_no_option_of_which_is_usable_refutes_the_assembly_at_once(direction):
    world = MaskSteps([[0], [], [0]])  # part 1 can never be placed
    rows = {0: [0.1, 0.9, 0.1], 0b111: [0.1, 0.9, 0.1]}
    result = VerifiedSearch(direction=direction).search(fixed_scores(rows, 3), world)
    assert result.outcome == Outcome.infeasible and result.checks == 1


@pytest.mark.parametrize("seed", range(12))
def test_exhaustive_mode_verifies_exactly_the_brute_force_orders(seed):
    rng = np.random.default_rng(seed)
    masks, touch = random_world(6, rng)
    truth = brute_force(MaskSteps(masks, touch))
    exact = FixationPrior.of_steps(MaskSteps(masks, touch)).allows
    for direction, frontier, learn, proves in itertools.product(
        Direction, Frontier, (True, False), (True, False)
    ):
        table = rng.random((64, 6))
        search = VerifiedSearch(k=None, direction=direction, frontier=frontier, learn_blocks=learn)
        result = search.search(
            lambda s, table=table: table[s],
            MaskSteps(masks, touch),
            exact if proves else None,
            prior_proves=proves,
        )
        assert set(result.verified.orders()) == set(truth.orders())
        assert {r.sequence for r in result.orders} == set(truth.orders())
        assert result.outcome == (Outcome.verified if truth.feasible else Outcome.infeasible)
        # each (state, part) at most once: forward among the brute force's (the reachable
        # states), backward among all of them
        bound = truth.checks if direction == Direction.forward else 6 * 2**5
        assert result.checks <= bound
        probabilities = [r.probability for r in result.orders]
        assert probabilities == sorted(probabilities, reverse=True)
        # first-order searches: verified, passing every step, or infeasible exactly when it is
        first = VerifiedSearch(direction=direction, frontier=frontier, learn_blocks=learn).search(
            lambda s, table=table: table[s],
            MaskSteps(masks, touch),
            exact if proves else None,
            prior_proves=proves,
        )
        assert first.outcome == result.outcome
        assert all(accepted_throughout(r.sequence, MaskSteps(masks, touch)) for r in first.orders)


@pytest.mark.parametrize("direction", list(Direction))
def test_k_orders_come_best_first_distinct_with_the_policys_probabilities(direction):
    masks, touch = [[0]] * 5, [0b11111 ^ (1 << p) for p in range(5)]  # every order works
    table = np.random.default_rng(3).random((32, 5))
    policy = lambda assembly, states: table[np.asarray(states)]  # noqa: E731
    result = VerifiedSearch(k=4, direction=direction).plan(
        policy, line_assembly(5), MaskSteps(masks, touch)
    )
    orders = [r.sequence for r in result.orders]
    assert len(orders) == 4 == len(set(orders))
    for r in result.orders:  # each probability is the product of its forward step scores
        state, steps = 0, []
        for part in r.sequence:
            steps.append(table[state][part])
            state |= 1 << part
        assert r.step_scores == pytest.approx(steps)
        assert r.probability == pytest.approx(np.prod(steps))
    assert [r.probability for r in result.orders] == sorted(
        (r.probability for r in result.orders), reverse=True
    )


def test_a_step_waiting_for_a_part_names_no_blockers_and_passes_once_it_is_placed():
    """Part 0's only option needs part 2 placed first (its open clamp is in the way) and is
    blocked by part 1: refused in {} for now, in {1} for good, placed in {2}."""
    world = MaskSteps([[(0b010, 0b100)], [0], [0]])
    assert world.check(0, 0) == StepCheck(False, None)
    assert world.check(0b010, 0) == StepCheck(False, (0b010,))
    assert world.check(0b100, 0) == StepCheck(True)
    for direction in Direction:
        result = VerifiedSearch(k=None, direction=direction).search(
            fixed_scores({}, 3), MaskSteps([[(0b010, 0b100)], [0], [0]])
        )
        assert {r.sequence for r in result.orders} == {(2, 0, 1)}


def test_minimal_masks_and_blocking_sets_taken_as_early_as_possible():
    assert minimal_masks([0b110, 0b010, 0b010, 0b101]) == [0b010, 0b101]
    # placed in the order 3, 1, 0, 2: each conflict is met by its earliest part, the conflict
    # whose earliest part came last first (part 2 alone meets two of the three)
    order = [3, 1, 0, 2]
    assert blocking_set((0b0110, 0b0100, 0b1001), order) == 0b1100
    assert blocking_set((0b0011, 0b0010), order) == 0b0010
    for conflicts in [(0b1010, 0b0101), (0b1111,), (0b0001, 0b1000)]:
        chosen = blocking_set(conflicts, order)
        assert all(c & chosen for c in conflicts)
    assert blocking_set((), order) == 0


@pytest.mark.parametrize("direction", list(Direction))
def test_an_exact_fixation_prior_drops_the_steps_it_refuses_without_a_check(direction):
    """Read off the checks' own rule, the prior refuses only steps on no order: the search
    never asks about them and reaches the same verdicts. Proofs of infeasibility cost fewer
    checks in all than when it only tries them last (not in every world: a refused step's
    check can name no blocker at all, which ends the search at once)."""
    spent = {False: 0, True: 0}
    for seed in range(40):
        masks, touch = random_world(7, np.random.default_rng(seed))
        prior = FixationPrior.of_steps(MaskSteps(masks, touch))
        truth = brute_force(MaskSteps(masks, touch))
        runs = {}
        for proves in (False, True):
            world = MaskSteps(masks, touch)
            result = VerifiedSearch(direction=direction).search(
                fixed_scores({}, 7), world, prior.allows, prior_proves=proves
            )
            assert result.outcome == (Outcome.verified if truth.feasible else Outcome.infeasible)
            runs[proves] = (result, world)
        asked = runs[True][1]._cache
        assert all(prior.allows(state, part) for state, part in asked)
        if not truth.feasible:
            for proves, (result, _) in runs.items():
                spent[proves] += result.checks
    assert spent[True] < spent[False]


def test_a_prior_without_the_fixation_rule_refuses_nothing():
    """Checks that do not enforce fixation give a prior that allows every step, so dropping
    what it refuses drops nothing."""
    prior = FixationPrior.of_steps(MaskSteps(LATE_BLOCK, None))
    assert all(prior.allows(s, p) for s in range(16) for p in range(4) if not s >> p & 1)
    strict = FixationPrior.of_steps(MaskSteps(LATE_BLOCK, LINE))
    assert not strict.allows(0b1101, 1) and strict.allows(0b0001, 1)


@pytest.mark.parametrize("seed", range(8))
def test_a_search_from_a_placed_state_finds_exactly_the_brute_forces_completions(seed):
    masks, touch = random_world(6, np.random.default_rng(seed))
    truth = brute_force(MaskSteps(masks, touch))
    exact = FixationPrior.of_steps(MaskSteps(masks, touch)).allows
    orders = list(truth.orders())
    for state in truth.states.tolist()[1:-1]:
        placed = state.bit_count()
        completions = {o[placed:] for o in orders if sum(1 << p for p in o[:placed]) == state}
        for k, learn in itertools.product((1, None), (True, False)):
            search = VerifiedSearch(k=k, direction=Direction.forward, learn_blocks=learn)
            result = search.search(
                fixed_scores({}, 6), MaskSteps(masks, touch), exact, prior_proves=True, start=state
            )
            found = {r.sequence for r in result.orders}
            assert result.outcome == (Outcome.verified if completions else Outcome.infeasible)
            assert found == completions if k is None else found <= completions
            assert all(len(r.sequence) == 6 - placed for r in result.orders)


def test_a_search_from_a_placed_state_runs_forward_and_has_something_left_to_place():
    world = MaskSteps(LATE_BLOCK)
    with pytest.raises(ValueError, match="runs forward"):
        VerifiedSearch(direction=Direction.backward).search(fixed_scores({}, 4), world, start=1)
    with pytest.raises(ValueError, match="nothing left"):
        VerifiedSearch(direction=Direction.forward).search(fixed_scores({}, 4), world, start=FULL)
