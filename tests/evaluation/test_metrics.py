import numpy as np
import pytest

from grace.evaluation.metrics import (
    LAMBDAS,
    feasibility_confusion,
    feasibility_roc,
    ir_precision,
    precision_at_k,
    sequence_auc,
    sequence_pr_curve,
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


def test_feasibility_confusion_and_roc():
    feasible = np.array([True, True, False, False, True])
    found = np.array([True, False, False, True, True])
    assert feasibility_confusion(feasible, found) == {"tp": 2, "fp": 1, "tn": 1, "fn": 1}
    fpr, tpr, roc = feasibility_roc(feasible, np.array([0.9, 0.2, 0.1, 0.6, 0.8]))
    assert roc == pytest.approx(5 / 6)  # 6 positive-negative pairs, only (0.2, 0.6) misordered
    assert fpr[-1] == tpr[-1] == 1.0
    assert np.isnan(feasibility_roc(np.ones(3, bool), np.ones(3))[2])
