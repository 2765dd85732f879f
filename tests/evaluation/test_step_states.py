from itertools import permutations

import numpy as np
import pytest

from grace.domain.orders import GroundTruth
from grace.evaluation.step_states import label_matrix, offpath_states, onpath_states

# Three parts. Feasible placements: first 0 or 1; after 0 only 2, and {0, 2} is a dead end;
# after 1 only 0, then 2. The one order is (1, 0, 2); starting with 0 is a wrong step.
DEAD_END_RULES = {0b000: (0, 1), 0b001: (2,), 0b010: (0,), 0b011: (2,)}
DEAD_END = GroundTruth.explore(3, lambda s, p: p in DEAD_END_RULES.get(s, ()))


def test_hand_case_on_and_off_the_true_order():
    states, masks = onpath_states(DEAD_END)
    assert dict(zip(states.tolist(), masks.tolist(), strict=True)) == {
        0b000: 0b010,  # only part 1 still completes
        0b010: 0b001,
        0b011: 0b100,
    }
    states, masks = offpath_states(DEAD_END)
    # {0}: placing 2 is feasible (labelled 1) though it cannot complete; {0, 2}: a dead end
    assert dict(zip(states.tolist(), masks.tolist(), strict=True)) == {0b001: 0b100, 0b101: 0}
    assert label_matrix(masks, 3).tolist() == [[False, False, True], [False, False, False]]


def test_infeasible_assembly_is_off_path_from_the_empty_state():
    truth = GroundTruth.explore(2, lambda s, p: s == 0)  # either first, then nothing
    states, masks = offpath_states(truth)
    assert dict(zip(states.tolist(), masks.tolist(), strict=True)) == {0: 0b11, 1: 0, 2: 0}
    assert onpath_states(truth)[0].tolist() == [0]


def _brute_force_offpath(n, can_place):
    """Reachable states by walking every prefix of every permutation; completable by trying
    every order of the remaining parts. Nothing from GroundTruth."""
    reachable = set()
    for order in permutations(range(n)):
        state = 0
        reachable.add(state)
        for part in order:
            if not can_place(state, part):
                break
            state |= 1 << part
            reachable.add(state)

    def completes(state):
        rest = [p for p in range(n) if not state >> p & 1]
        for order in permutations(rest):
            s = state
            for part in order:
                if not can_place(s, part):
                    break
                s |= 1 << part
            else:
                return True
        return False

    full = (1 << n) - 1
    return {
        s: sum(1 << p for p in range(n) if not s >> p & 1 and can_place(s, p))
        for s in reachable
        if s != full and not completes(s)
    }


@pytest.mark.parametrize("n,seed", [(3, 6), (4, 1), (4, 2), (5, 3), (5, 4)])
def test_offpath_states_equal_a_brute_force_listing(n, seed):
    rng = np.random.default_rng(seed)
    table = rng.random((1 << n, n)) < 0.55  # a random feasibility rule per (state, part)

    def can_place(state, part):
        return bool(table[state, part])

    states, masks = offpath_states(GroundTruth.explore(n, can_place))
    expected = _brute_force_offpath(n, can_place)
    assert expected  # every case has dead ends
    assert dict(zip(states.tolist(), masks.tolist(), strict=True)) == expected
