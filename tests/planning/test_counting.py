import numpy as np
import pytest
from planning_fakes import TableScorer, line_assembly

from grace.domain.orders import GroundTruth
from grace.planning.counting import best_probability, bottleneck, retrieval_counts
from grace.planning.sequences import plan, score_states


def _precedence_truth(n: int, seed: int) -> GroundTruth:
    rng = np.random.default_rng(seed)
    before = rng.random((n, n)) < 0.25  # before[p, q]: p needs q placed first

    def can_place(state: int, part: int) -> bool:
        return all(state >> q & 1 for q in range(n) if before[part, q] and q != part)

    return GroundTruth.explore(n, can_place)


@pytest.mark.parametrize("n,seed", [(4, 0), (5, 1), (6, 2)])
def test_counts_equal_listing_at_every_threshold(n, seed):
    truth = _precedence_truth(n, seed)
    scored = score_states(TableScorer(n, seed), line_assembly(n))
    lams = np.array([0.0, 0.1, 0.35, 0.5, 0.9])
    retrieved, hits = retrieval_counts(scored, truth, lams)
    orders = set(truth.orders())
    for j, lam in enumerate(lams):
        listed = [tuple(s) for s in plan(scored, lam).sequences.tolist()]
        assert retrieved[j] == len(listed)
        assert hits[j] == sum(s in orders for s in listed)


def test_bottleneck_is_the_last_threshold_with_a_sequence():
    n = 5
    scored = score_states(TableScorer(n, 7), line_assembly(n))
    b = bottleneck(scored)
    assert len(plan(scored, b)) > 0
    assert len(plan(scored, np.nextafter(b, 2.0))) == 0


@pytest.mark.parametrize("n,seed", [(3, 0), (5, 4), (6, 5)])
def test_best_probability_is_the_most_probable_listed_sequence(n, seed):
    scored = score_states(TableScorer(n, seed, levels=1000), line_assembly(n))
    listed = plan(scored, 0.0)
    assert best_probability(scored) == pytest.approx(listed.probabilities.max(), rel=1e-12)
    assert bottleneck(scored) == pytest.approx(listed.step_scores.min(axis=1).max())
