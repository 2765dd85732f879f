import numpy as np
import pytest
from planning_fakes import TableScorer, line_assembly

from grace.planning.sequences import plan, score_states
from grace.planning.topk import lazy_scores, rank_sequences, table_scores, top_k


@pytest.mark.parametrize("n,seed,lam", [(4, 0, 0.0), (5, 1, 0.3), (6, 2, 0.5), (6, 3, 0.0)])
def test_top_k_equals_full_listing_sorted_by_probability(n, seed, lam):
    scorer = TableScorer(n, seed, levels=1000)
    scored = score_states(scorer, line_assembly(n))
    full = plan(scored, lam)
    order = sorted(
        range(len(full)), key=lambda i: (-full.probabilities[i], tuple(full.sequences[i]))
    )
    best, _ = top_k(table_scores(scored), n, 5, lam)
    assert [r.sequence for r in best] == [tuple(full.sequences[i]) for i in order[:5]]
    assert [r.probability for r in best] == [full.probabilities[i] for i in order[:5]]


def test_lazy_top_k_on_ten_parts_scores_few_states():
    n = 10
    rng = np.random.default_rng(0)
    preferred = rng.permutation(n)
    calls = []

    def scorer(assembly, states):
        calls.extend(states.tolist())
        out = np.zeros((len(states), n))
        for row, state in enumerate(states.tolist()):
            free = [p for p in preferred if not state >> p & 1]
            out[row, free] = 0.55
            out[row, free[0]] = 0.95  # the preferred next part
        return out

    best, _ = top_k(lazy_scores(scorer, line_assembly(n)), n, 3, 0.5)
    assert best[0].sequence == tuple(int(p) for p in preferred)
    assert best[0].probability >= best[1].probability >= best[2].probability
    assert np.isclose(best[0].probability, 0.95**n)
    assert len(calls) == len(set(calls)) < 100  # 2^10 states, 3,628,800 orders: never listed


def test_above_the_full_table_the_listing_stops_at_its_budget_and_says_so():
    """21 parts, an undecided model (every step 0.5): best-first search without completion
    bounds would expand every prefix of every length before a complete one; either budget ends
    it, with what it found (nothing) and `stopped` set. A search that ends by itself is not."""
    n = 21

    def undecided(assembly, states):
        return np.full((len(states), assembly.n_parts), 0.5)

    timed = rank_sequences(undecided, line_assembly(n), 3, max_seconds=0.05)
    assert timed.ranked == [] and timed.stopped and timed.feasibility is None
    counted = rank_sequences(undecided, line_assembly(n), 3, max_expansions=200)
    assert counted.ranked == [] and counted.stopped and counted.passes <= 200  # states scored
    small = rank_sequences(undecided, line_assembly(3), 10, max_seconds=0.05)
    assert len(small.ranked) == 6 and not small.stopped  # all 3! orders
