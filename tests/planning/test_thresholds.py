"""The relative threshold against the paper's absolute λ (grace/planning/thresholds.py)."""

import numpy as np
from planning_fakes import TableScorer, line_assembly

from grace.planning.sequences import plan, score_states, unplaced
from grace.planning.thresholds import AbsoluteThreshold, RelativeThreshold, relative_scores

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
