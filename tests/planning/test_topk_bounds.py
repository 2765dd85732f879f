"""Best-first top-k with exact completion bounds (A*): same sequences, far fewer expansions."""

import numpy as np
import pytest
from planning_fakes import TableScorer, line_assembly

from grace.planning.counting import best_probability
from grace.planning.sequences import plan, score_states
from grace.planning.topk import completion_bounds, rank_sequences, table_scores, top_k


@pytest.mark.parametrize("n,seed,lam", [(4, 0, 0.0), (5, 1, 0.3), (6, 2, 0.5), (7, 3, 0.0)])
def test_bounded_top_k_equals_the_full_listing(n, seed, lam):
    scored = score_states(TableScorer(n, seed, levels=10**9), line_assembly(n))  # no ties
    full = plan(scored, lam)
    order = np.argsort(-full.probabilities, kind="stable")[:8]
    best, _ = top_k(table_scores(scored), n, 8, lam, completion_bounds(scored, lam))
    assert [r.sequence for r in best] == [tuple(full.sequences[i]) for i in order]
    assert [r.probability for r in best] == [full.probabilities[i] for i in order]
    bounds = completion_bounds(scored, 0.0)
    assert np.isclose(bounds[0], best_probability(scored))  # forward and backward DP agree


def test_uniform_scores_do_not_expand_every_prefix():
    n = 10  # 10! = 3.6 million orders, all equally probable
    scored = score_states(lambda a, s: np.full((len(s), n), 0.5), line_assembly(n))
    expanded = []

    def scores(state):
        expanded.append(state)
        return scored.table[state]

    best, _ = top_k(scores, n, 10, 0.0, completion_bounds(scored, 0.0))
    assert len(best) == 10 and all(np.isclose(r.probability, 0.5**n) for r in best)
    assert len(expanded) < 10 * n * n


def test_ties_go_to_the_tie_order():
    n = 5
    scored = score_states(lambda a, s: np.full((len(s), n), 0.5), line_assembly(n))
    bounds = completion_bounds(scored, 0.0)
    assert top_k(table_scores(scored), n, 1, 0.0, bounds)[0][0].sequence == (0, 1, 2, 3, 4)
    ranks = np.array([3, 0, 4, 1, 2])  # part 1 first, then 3, 4, 0, 2
    best, _ = top_k(table_scores(scored), n, 2, 0.0, bounds, tie_order=ranks)
    assert [r.sequence for r in best] == [(1, 3, 4, 0, 2), (1, 3, 4, 2, 0)]


def test_rank_sequences_gives_the_bottleneck_as_feasibility():
    n = 6
    scorer = TableScorer(n, 5, levels=10**9)
    ranking = rank_sequences(scorer, line_assembly(n), 3)
    scored = score_states(TableScorer(n, 5, levels=10**9), line_assembly(n))
    full = plan(scored, 0.0)
    assert ranking.feasibility == pytest.approx(full.step_scores.min(axis=1).max())
    assert ranking.ranked[0].probability == pytest.approx(full.probabilities.max())
