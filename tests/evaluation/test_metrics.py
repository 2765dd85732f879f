import numpy as np
import pytest

from grace.evaluation.metrics import (
    LAMBDAS,
    feasibility_confusion,
    feasibility_roc,
    ir_precision,
    pass_rate,
    precision_at_k,
    sequence_auc,
    sequence_pr_curve,
    state_leakage,
    tpr_at_fpr,
)


def test_lambda_grid_is_100_values_in_unit_interval():
    assert len(LAMBDAS) == 100 and LAMBDAS[0] == 0.0 and LAMBDAS[-1] < 1.0


def test_empty_retrieval_has_precision_one():
    assert ir_precision(np.array([0, 1, 2]), np.array([0, 2, 2])).tolist() == [1.0, 0.5, 1.0]


def test_perfect_policy_has_sequence_auc_one():
    # 2 of 6 orders are ground truth; the policy scores them 1 and the others 0, so at λ = 0
    # everything is retrieved (precision 1/3) and at every λ > 0 exactly the truth.
    retrieved = np.full((1, 100), 2.0)
    retrieved[0, 0] = 6.0
    hits = np.full((1, 100), 2.0)
    recall, precision = sequence_pr_curve(retrieved, hits, np.array([2]))
    assert recall[0] == 0.0 and precision[0] == 1.0 and recall[-1] == 1.0 and precision[-1] == 0
    assert sequence_auc(retrieved, hits, np.array([2])) == pytest.approx(1.0)


def test_policy_that_never_finds_anything_has_auc_one_half():
    # recall 0 and (empty-retrieval) precision 1 everywhere: the closed curve is the diagonal
    zeros = np.zeros((3, 100))
    assert sequence_auc(zeros, zeros, np.array([1, 2, 3])) == pytest.approx(0.5)


def test_strict_sequence_auc_gives_an_empty_retrieval_precision_zero():
    zeros = np.zeros((3, 100))
    assert sequence_auc(zeros, zeros, np.array([1, 2, 3]), empty_precision=0.0) == 0.0
    # A retrieves its one true order at every λ; B retrieves nothing above λ = 0.49 and its two
    # orders among 4 below. Paper rule: B's empty retrievals have precision 1; strict: 0.
    retrieved = np.array([[1.0] * 100, [4.0] * 50 + [0.0] * 50])
    hits = np.array([[1.0] * 100, [2.0] * 50 + [0.0] * 50])
    relevant = np.array([1, 2])
    # from high λ: 50 points (recall 0.5, precision (1 + e) / 2), then 50 at (1, (1 + 0.5) / 2)
    for empty, high in ((1.0, 1.0), (0.0, 0.5)):
        area = 0.5 * (1 + high) / 2 + 0.5 * (high + 0.75) / 2
        assert sequence_auc(retrieved, hits, relevant, empty) == pytest.approx(area)
    assert sequence_auc(retrieved, hits, relevant, 0.0) < sequence_auc(retrieved, hits, relevant)


def test_pass_rate_and_state_leakage_count_what_reaches_lambda():
    assert pass_rate(np.array([0.2, 0.5, 0.49, 0.9]), 0.5) == 0.5  # 0.5 and 0.9 pass
    assert np.isnan(pass_rate(np.zeros(0), 0.5))
    scores = np.array([[0.9, 0.1, 0.2], [0.4, 0.6, 0.0], [0.3, 0.3, 0.3]])
    unplaced = np.array([[False, True, True], [True, True, True], [True, True, False]])
    # row 0: only the placed part reaches λ (no leak); row 1 leaks through part 1; row 2 does not
    assert state_leakage(scores, unplaced, 0.5) == pytest.approx(1 / 3)
    assert np.isnan(state_leakage(np.zeros((0, 3)), np.zeros((0, 3), bool), 0.5))


def test_sequence_auc_averages_precision_and_recall_over_assemblies():
    # one λ-independent retrieval per assembly: A hits 1 of 2 retrieved (REL 1), B hits 1 of 1
    # retrieved (REL 2). Mean precision (0.5 + 1) / 2 = 0.75, mean recall (1 + 0.5) / 2 = 0.75.
    retrieved = np.array([[2.0] * 100, [1.0] * 100])
    hits = np.array([[1.0] * 100, [1.0] * 100])
    recall, precision = sequence_pr_curve(retrieved, hits, np.array([1, 2]))
    assert recall[1:-1] == pytest.approx([0.75] * 100)
    assert precision[1:-1] == pytest.approx([0.75] * 100)
    # (0,1) → (0.75,0.75) → (1,0): 0.75·(1+0.75)/2 + 0.25·0.75/2
    assert sequence_auc(retrieved, hits, np.array([1, 2])) == pytest.approx(0.75)
    assert np.isnan(sequence_auc(np.zeros((0, 100)), np.zeros((0, 100)), np.array([])))


def test_precision_at_k_counts_only_assemblies_with_k_orders_and_reports_empty():
    flags = [[True, False, True], [], [False], [True, True]]
    relevant = [3, 2, 1, 2]
    p1 = precision_at_k(flags, relevant, 1)
    assert p1 == {"value": pytest.approx((1 + 1 + 0 + 1) / 4), "assemblies": 4, "empty": 1}
    p2 = precision_at_k(flags, relevant, 2)
    assert p2 == {"value": pytest.approx((0.5 + 1 + 1) / 3), "assemblies": 3, "empty": 1}
    p3 = precision_at_k(flags, relevant, 3)
    assert p3 == {"value": pytest.approx(2 / 3), "assemblies": 1, "empty": 0}
    assert np.isnan(precision_at_k(flags, relevant, 4)["value"])


def test_strict_precision_at_k_counts_an_empty_retrieval_as_a_miss():
    flags = [[True, False, True], [], [False], [True, True]]
    relevant = [3, 2, 1, 2]
    strict = precision_at_k(flags, relevant, 1, empty_value=0.0)
    assert strict == {"value": pytest.approx((1 + 0 + 0 + 1) / 4), "assemblies": 4, "empty": 1}
    assert precision_at_k(flags, relevant, 2, empty_value=0.0)["value"] == pytest.approx(0.5)
    # a policy that never retrieves: the paper's rule gives 1, the strict one 0
    never = [[], [], []]
    assert precision_at_k(never, [1, 2, 3], 1)["value"] == 1.0
    assert precision_at_k(never, [1, 2, 3], 1, empty_value=0.0)["value"] == 0.0


def test_feasibility_confusion_and_roc():
    feasible = np.array([True, True, False, False, True])
    found = np.array([True, False, False, True, True])
    assert feasibility_confusion(feasible, found) == {"tp": 2, "fp": 1, "tn": 1, "fn": 1}
    fpr, tpr, roc = feasibility_roc(feasible, np.array([0.9, 0.2, 0.1, 0.6, 0.8]))
    assert roc == pytest.approx(5 / 6)  # 6 positive-negative pairs, only (0.2, 0.6) misordered
    assert fpr[-1] == tpr[-1] == 1.0
    assert np.isnan(feasibility_roc(np.ones(3, bool), np.ones(3))[2])


def test_tpr_at_five_percent_fpr_and_roc_auc_on_a_hand_case():
    # 4 feasible, 20 infeasible. Descending: .9 P, .8 P, .7 N, .6 P, .5 N, .4 P, then 18 N < .4.
    # FPR ≤ 1/20 admits thresholds down to .6 (only .7 is a false positive): TPR 3/4. AUC: the
    # positives outrank 20 + 20 + 19 + 18 of the 20 negatives each: 77 / 80.
    feasible = np.array([True] * 4 + [False] * 20)
    scores = np.array([0.9, 0.8, 0.6, 0.4, 0.7, 0.5, *np.linspace(0.0, 0.3, 18)])
    fpr, tpr, auc = feasibility_roc(feasible, scores)
    assert auc == pytest.approx(77 / 80)
    assert tpr_at_fpr(fpr, tpr, 0.05) == 0.75
    assert tpr_at_fpr(fpr, tpr, 0.0) == 0.5
    assert tpr_at_fpr(fpr, tpr, 0.1) == 1.0
