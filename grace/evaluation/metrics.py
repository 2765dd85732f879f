"""The paper's metrics (Sec. V-A.2, Metrics) and their strict twins, as pure functions on arrays.

Definitions, with the floors that read them honestly, are in docs/metrics.md. No model or planner
imports: everything here takes counts, scores and labels.
"""

from __future__ import annotations

import numpy as np
from sklearn.metrics import auc, precision_recall_curve, roc_auc_score, roc_curve


def step_auc(scores: np.ndarray, labels: np.ndarray) -> float:
    """Step-by-step AUC: area under the precision–recall curve of part scores vs next-step labels.

    Undefined (NaN) when no label is positive.
    """
    labels = np.asarray(labels).ravel().astype(bool)
    if not labels.any():
        return float("nan")
    precision, recall, _ = precision_recall_curve(labels, np.asarray(scores).ravel())
    return float(auc(recall, precision))


LAMBDAS = np.arange(100) / 100.0
"""The λ sweep of the complete-sequence AUC: 100 values in [0, 1) (docs/metrics.md)."""


def ir_precision(
    hits: np.ndarray, retrieved: np.ndarray, empty_precision: float = 1.0
) -> np.ndarray:
    """|RET ∩ REL| / |RET|, and `empty_precision` where nothing was retrieved: 1 by the paper's
    empty-retrieval rule, 0 for the strict twin."""
    hits, retrieved = np.asarray(hits, dtype=float), np.asarray(retrieved, dtype=float)
    out = np.full_like(hits, empty_precision)
    return np.divide(hits, retrieved, out=out, where=retrieved > 0)


def sequence_pr_curve(
    retrieved: np.ndarray, hits: np.ndarray, relevant: np.ndarray, empty_precision: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Mean IR recall and precision over assemblies per λ, closed by (0, 1) and (1, 0).

    `retrieved` and `hits` are (assemblies, λ) counts of |RET| and |RET ∩ REL|, `relevant` the
    |REL| per assembly; only assemblies with |REL| > 0 are given (recall is undefined otherwise).
    Points run from the highest λ to the lowest, so recall never decreases along the curve. An
    empty retrieval has precision `empty_precision` (ir_precision).
    """
    retrieved, hits = np.atleast_2d(retrieved), np.atleast_2d(hits)
    relevant = np.asarray(relevant, dtype=float)[:, None]
    if (relevant <= 0).any():
        raise ValueError("sequence_pr_curve: every assembly needs ≥ 1 ground-truth sequence")
    precision = ir_precision(hits, retrieved, empty_precision).mean(axis=0)[::-1]
    recall = (hits / relevant).mean(axis=0)[::-1]
    return np.concatenate([[0.0], recall, [1.0]]), np.concatenate([[1.0], precision, [0.0]])


def sequence_auc(
    retrieved: np.ndarray, hits: np.ndarray, relevant: np.ndarray, empty_precision: float = 1.0
) -> float:
    """Complete-sequence AUC: area under the closed mean IR precision–recall curve (paper,
    Sec. V-A.2, Metrics; the closing points are in docs/metrics.md). `empty_precision=0` gives
    the strict twin, where a planner that retrieves nothing scores 0 instead of 0.5.

    NaN when no assembly has a ground-truth sequence.
    """
    if len(relevant) == 0:
        return float("nan")
    recall, precision = sequence_pr_curve(retrieved, hits, relevant, empty_precision)
    return float(auc(recall, precision))


def pass_rate(scores: np.ndarray, threshold: float) -> float:
    """Share of `scores` (one per step) at or above `threshold`: the steps Algorithm 1 takes at
    λ = threshold. NaN without steps. Read on the feasible steps into dead ends it is the
    dead-end pass rate (docs/metrics.md)."""
    scores = np.asarray(scores, dtype=float).ravel()
    return float(np.mean(scores >= threshold)) if scores.size else float("nan")


def state_leakage(scores: np.ndarray, unplaced: np.ndarray, threshold: float) -> float:
    """Share of states (rows of `scores`, (states, N)) in which some unplaced part scores at or
    above `threshold`, i.e. from which Algorithm 1 goes on. NaN without states. Read on the
    states from which no order completes it is the dead-end state leakage (docs/metrics.md)."""
    scores = np.asarray(scores, dtype=float)
    if not scores.shape[0]:
        return float("nan")
    return float(np.mean(((scores >= threshold) & np.asarray(unplaced, dtype=bool)).any(axis=1)))


def precision_at_k(
    topk_relevant: list[list[bool]], relevant: np.ndarray, k: int, empty_value: float = 1.0
) -> dict:
    """P@k: IR precision of the k most probable retrieved sequences (paper, Sec. V-A.2, Metrics).

    `topk_relevant[a]` flags, best first, whether each retrieved sequence of assembly `a` is a
    ground-truth one (at least its first k). Only assemblies with ≥ k ground-truth sequences
    count. An assembly with no retrieved sequence scores `empty_value`: 1 by the paper's
    empty-retrieval rule, 0 for the strict P@k (a planner that returns nothing for a feasible
    assembly has failed it). `empty` says how many of the counted assemblies that was; `value` is
    NaN if none count.
    """
    counted = [flags[:k] for flags, n in zip(topk_relevant, relevant, strict=True) if n >= k]
    values = [float(np.mean(flags)) if flags else empty_value for flags in counted]
    return {
        "value": float(np.mean(values)) if values else float("nan"),
        "assemblies": len(counted),
        "empty": sum(not flags for flags in counted),
    }


def feasibility_confusion(feasible: np.ndarray, found: np.ndarray) -> dict[str, int]:
    """Confusion counts (positive = feasible); predicted feasible iff a sequence is found."""
    feasible, found = np.asarray(feasible, dtype=bool), np.asarray(found, dtype=bool)
    return {
        "tp": int((feasible & found).sum()),
        "fp": int((~feasible & found).sum()),
        "tn": int((~feasible & ~found).sum()),
        "fn": int((feasible & ~found).sum()),
    }


def feasibility_roc(
    feasible: np.ndarray, score: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """ROC (FPR, TPR) and its AUC for a feasibility score; NaN AUC unless both classes occur.

    ROC AUC does not depend on the class ratio, so it equals the paper's balanced-set figure in
    expectation without discarding assemblies.
    """
    feasible = np.asarray(feasible, dtype=bool)
    if feasible.all() or not feasible.any():
        return np.array([0.0, 1.0]), np.array([0.0, 1.0]), float("nan")
    fpr, tpr, _ = roc_curve(feasible, np.asarray(score, dtype=float))
    return fpr, tpr, float(roc_auc_score(feasible, score))


def tpr_at_fpr(fpr: np.ndarray, tpr: np.ndarray, max_fpr: float = 0.05) -> float:
    """The highest TPR of a threshold whose FPR is ≤ `max_fpr` (no interpolation between
    thresholds: every point is one a deterministic classifier reaches). NaN for an undefined ROC.
    """
    fpr, tpr = np.asarray(fpr, dtype=float), np.asarray(tpr, dtype=float)
    allowed = fpr <= max_fpr + 1e-12
    return float(tpr[allowed].max()) if allowed.any() else float("nan")
