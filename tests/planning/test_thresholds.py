"""The relative and lifted thresholds against the paper's absolute λ
(grace/planning/thresholds.py)."""

import numpy as np
from planning_fakes import TableScorer, line_assembly

from grace.planning.sequences import plan, score_states, unplaced
from grace.planning.thresholds import (
    AbsoluteThreshold,
    LiftedThreshold,
    RelativeThreshold,
    lifted_scores,
    relative_scores,
)

N = 6


def calibrated(seed: int):
    """Random scores whose best unplaced part scores exactly 1 in every state."""
    table = TableScorer(N, seed).table
    states = np.arange(len(table))
    free = unplaced(states, N)
    best = np.where(free, table, -1.0).argmax(axis=1)
    table[states, best] = np.where(free.any(axis=1), 1.0, table[states, best])
    return lambda assembly, s: table[np.asarray(s)]


def retrieved(scorer, lam: float) -> set[tuple[int, ...]]:
    found = plan(score_states(scorer, line_assembly(N)), lam)
    return {tuple(int(p) for p in seq) for seq in found.sequences}


def test_relative_retrieves_what_lambda_does_when_scores_are_calibrated():
    for seed in range(4):
        scorer = calibrated(seed)
        for lam in (0.3, 0.5, 0.7):
            absolute = retrieved(AbsoluteThreshold()(scorer), lam)
            assert absolute  # a real case, not two empty sets
            assert retrieved(RelativeThreshold(floor=0.05)(scorer), lam) == absolute


def test_relative_retrieves_more_when_scores_are_uniformly_scaled_down():
    for seed in range(4):
        scorer = calibrated(seed)
        lower = lambda assembly, s, scorer=scorer: 0.6 * scorer(assembly, s)  # noqa: E731
        calibrated_set = retrieved(AbsoluteThreshold()(scorer), 0.5)
        absolute = retrieved(AbsoluteThreshold()(lower), 0.5)
        relative = retrieved(RelativeThreshold(floor=0.05)(lower), 0.5)
        assert relative == calibrated_set  # the ranking, not the scale, decides
        assert absolute < relative  # λ cuts valid steps whose scale fell


def test_floor_and_placed_parts_open_no_branch():
    states = np.array([0b000, 0b001, 0b011])
    scores = np.array([[0.2, 0.1, 0.02], [0.9, 0.03, 0.01], [0.5, 0.5, -1.0]])
    shares = relative_scores(scores, states, floor=0.05)
    np.testing.assert_allclose(shares[0], [1.0, 0.5, 0.0])  # 0.02 < floor: cut
    np.testing.assert_allclose(shares[1], [0.0, 0.0, 0.0])  # everything left below the floor
    np.testing.assert_allclose(shares[2], [0.0, 0.0, -1.0])  # a negative score stays below λ = 0
    assert relative_scores(np.zeros((1, 3)), np.zeros(1, dtype=np.int64), 0.0).tolist() == [
        [0.0, 0.0, 0.0]
    ]


def greedy(scorer) -> tuple[int, ...]:
    """The sequence that takes the best unplaced part in every state."""
    state, order = 0, []
    for _ in range(N):
        scores = scorer(None, [state])[0]
        part = int(np.where(unplaced(np.array([state]), N)[0], scores, -np.inf).argmax())
        order.append(part)
        state |= 1 << part
    return tuple(order)


def test_lifted_plans_as_lambda_wherever_a_part_clears_it():
    for seed in range(4):
        scorer = calibrated(seed)
        states = np.arange(2**N - 1)
        table = scorer(None, states)
        np.testing.assert_array_equal(LiftedThreshold()(scorer)(None, states), table)
        assert retrieved(LiftedThreshold()(scorer), 0.5) == retrieved(scorer, 0.5)


def test_lifted_follows_the_best_part_where_nothing_clears_lambda():
    for seed in range(4):
        scorer = calibrated(seed)
        lower = lambda assembly, s, scorer=scorer: 0.4 * scorer(assembly, s)  # noqa: E731
        assert retrieved(lower, 0.5) == set()  # every state's best is 0.4 < λ
        lifted = retrieved(LiftedThreshold(level=0.5)(lower), 0.5)
        assert lifted == {greedy(scorer)}  # one branch per lifted state: its best part
        assert lifted <= retrieved(scorer, 0.5)


def test_lifted_keeps_the_floor_and_placed_parts():
    states = np.array([0b000, 0b001, 0b100, 0b000])
    scores = np.array([[0.2, 0.1, 0.02], [0.9, 0.03, 0.01], [0.3, 0.2, 0.9], [0.01, 0.02, 0.04]])
    lifted = lifted_scores(scores, states, level=0.5, floor=0.05)
    np.testing.assert_allclose(lifted[0], [0.5, 0.25, 0.05])  # scaled: the best scores λ
    np.testing.assert_allclose(lifted[1], scores[1])  # the unplaced best 0.03 < floor: stops
    np.testing.assert_allclose(lifted[2], [0.5, 0.2 / 0.6, 0.9])  # placed part 2 kept as is
    np.testing.assert_allclose(lifted[3], scores[3])  # the best is below the floor: stops
