import math

import numpy as np
import pytest
from planning_fakes import TableScorer, line_assembly, traverse

from grace.planning.sequences import plan, score_states


@pytest.mark.parametrize("n,seed", [(3, 0), (4, 1), (5, 2), (5, 3), (6, 4)])
def test_planner_equals_reference_recursion(n, seed):
    assembly = line_assembly(n)
    scorer = TableScorer(n, seed)
    scored = score_states(scorer, assembly)
    for lam in (0.0, 0.2, 0.5, 0.7):
        ref, ref_dead, _ = traverse(scorer, assembly, lam)
        got = plan(scored, lam)
        assert [tuple(s) for s in got.sequences.tolist()] == [r[0] for r in ref]
        assert got.probabilities.tolist() == [r[1] for r in ref]  # bit for bit
        assert [tuple(s) for s in got.step_scores.tolist()] == [r[2] for r in ref]
        assert sorted(got.dead_ends) == sorted(ref_dead)


def test_each_state_scored_once_batched_by_level():
    n = 7
    scorer = TableScorer(n, 0)
    scorer.table[:] = 0.9
    scored = score_states(scorer, line_assembly(n))
    assert scored.passes == scorer.states == 2**n - 1
    result = plan(scored, 0.5)
    assert len(result) == math.factorial(n)
    assert np.allclose(result.probabilities, 0.9**n)
    _, _, prefix_passes = traverse(scorer, line_assembly(n), 0.0)
    assert prefix_passes == sum(math.factorial(n) // math.factorial(n - k) for k in range(n))


def test_threshold_prunes_reachable_states_and_reports_dead_ends():
    n = 3
    scorer = TableScorer(n, 0)
    scorer.table[:] = 0.0
    scorer.table[0, 0] = 0.8  # only part 0 first
    scorer.table[0b001, 1] = 0.6  # then only part 1, and from {0, 1} nothing: a dead end
    scored = score_states(scorer, line_assembly(n), threshold=0.5)
    assert sorted(scored.scored().tolist()) == [0, 0b001, 0b011]
    result = plan(scored, 0.5)
    assert len(result) == 0
    assert result.dead_ends == [(0, 1)]
    with pytest.raises(ValueError, match="threshold"):
        plan(scored, 0.1)


def test_scorer_with_wrong_shape_is_rejected():
    with pytest.raises(ValueError, match="one score per part"):
        score_states(lambda a, s: np.zeros((len(s), 2)), line_assembly(3))
