"""Feasibility schemes, scored per test size by ROC AUC and TPR at FPR 0.05 (docs/metrics.md).

A scheme maps an assembly to a score for "feasible"; positives are feasible assemblies (paper,
Sec. V-A.2). The paper's schemes (Sec. IV-C.4, Fig. 5) and ours beside them:

- from planning (no extra training): `sequences` (how many complete sequences Algorithm 1
  retrieves at λ, the paper's "#sequences" indicator), `best_sequence` (the probability of the
  most probable complete sequence) and `bottleneck` (the best sequence's lowest step: thresholded
  at λ it is exactly "Algorithm 1 finds a sequence at λ");
- from the mean-pooled part embeddings of the trained GRACE: scikit-learn classifiers fitted on
  the training assemblies (`classifier: <name>`), and densities fitted on the feasible training
  assemblies only, scored by log-likelihood (`density: <name>`, grace/evaluation/density.py).

Per-fold summaries keep their ROC points; across folds the report averages AUC and TPR and the
curves (TPR averaged at fixed FPRs).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from sklearn.base import clone

from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.evaluation.feasibility_classifier import classifier_scores, pooled_embeddings
from grace.evaluation.metrics import feasibility_roc, tpr_at_fpr
from grace.evaluation.report import mean_std
from grace.evaluation.results import plain
from grace.planning.counting import best_probability, bottleneck, retrieval_counts
from grace.planning.sequences import ScoredStates, Scorer, score_states

PLANNING_SCHEMES = ("sequences", "best_sequence", "bottleneck")
MAX_FPR = 0.05
"""The false-positive rate at which the TPR is reported: an infeasible assembly sent to the cell
once in twenty."""
ROC_GRID = np.linspace(0.0, 1.0, 101)
MIN_DENSITY_FIT = 32
"""Fewest feasible training assemblies a density is fitted on: a density in the 16 dimensions of
grace/conf/task/feasibility.yaml's PCA needs more points than that, and a few dozen to mean
anything."""

log = logging.getLogger(__name__)


def scheme_summary(feasible: Sequence[bool], scores: Sequence[float]) -> dict:
    """ROC AUC, TPR at FPR ≤ MAX_FPR and the ROC points of one scheme on one fold and size
    (NaN and an empty curve when the assemblies hold only one class)."""
    feasible = np.asarray(feasible, dtype=bool)
    # −inf (no complete path was scored at all) ranks lowest; ROC needs finite scores
    big = np.finfo(float).max
    scores = np.nan_to_num(np.asarray(scores, dtype=float), nan=-big, neginf=-big, posinf=big)
    fpr, tpr, auc = feasibility_roc(feasible, scores)
    defined = not np.isnan(auc)
    return {
        "roc_auc": auc,
        "tpr_at_fpr": tpr_at_fpr(fpr, tpr, MAX_FPR) if defined else float("nan"),
        "roc": {"fpr": fpr.tolist(), "tpr": tpr.tolist()} if defined else None,
        "assemblies": len(feasible),
        "feasible": int(feasible.sum()),
    }


def planning_scores(scored: ScoredStates, truth: GroundTruth, threshold: float) -> dict[str, float]:
    """The planning schemes' scores of one assembly from its states scored at λ = 0."""
    retrieved, _ = retrieval_counts(scored, truth, np.array([threshold]))
    return {
        "sequences": float(retrieved[0]),
        "best_sequence": best_probability(scored),
        "bottleneck": bottleneck(scored),
    }


def planning_schemes(
    scorer: Scorer, samples: Sequence[LabelledAssembly], threshold: float
) -> dict[str, dict[int, dict]]:
    """{scheme: {size: summary}} of the planning schemes of `scorer` on `samples`."""
    scores = [
        planning_scores(score_states(scorer, s.assembly, 0.0), s.truth, threshold) for s in samples
    ]
    return {
        name: _per_size(samples, np.array([x[name] for x in scores])) for name in PLANNING_SCHEMES
    }


def _per_size(
    samples: Sequence[LabelledAssembly], scores: np.ndarray | None
) -> dict[int, dict] | None:
    if scores is None:
        return None
    out = {}
    for size in sorted({s.size for s in samples}):
        chosen = [i for i, s in enumerate(samples) if s.size == size]
        out[size] = scheme_summary([samples[i].truth.feasible for i in chosen], scores[chosen])
    return out


def embedding_schemes(
    module: Any,
    train: Sequence[LabelledAssembly],
    test: Sequence[LabelledAssembly],
    classifiers: Mapping[str, Any] | None = None,
    densities: Mapping[str, Any] | None = None,
) -> dict[str, dict[int, dict]]:
    """{scheme: {size: summary}} of classifiers and densities on the module's pooled embeddings.

    Classifiers are fitted on every training assembly (skipped when it holds one class only),
    densities on its feasible assemblies only (skipped below MIN_DENSITY_FIT of them); both are
    cloned, the given estimators stay unfitted.
    """
    classifiers, densities = classifiers or {}, densities or {}
    if not classifiers and not densities:
        return {}
    x_train, x_test = pooled_embeddings(module, train), pooled_embeddings(module, test)
    feasible = np.array([s.truth.feasible for s in train])
    out: dict[str, dict[int, dict]] = {}
    for name, estimator in classifiers.items():
        summary = _per_size(test, classifier_scores(estimator, x_train, feasible, x_test))
        if summary is not None:
            out[f"classifier: {name}"] = summary
    if densities and feasible.sum() < MIN_DENSITY_FIT:
        log.warning(
            "densities skipped: %d feasible training assemblies, need %d",
            feasible.sum(),
            MIN_DENSITY_FIT,
        )
    elif densities:
        for name, density in densities.items():
            fitted = clone(density).fit(x_train[feasible])
            out[f"density: {name}"] = _per_size(test, fitted.score_samples(x_test))
    return out


def add_schemes(
    metrics: dict[int, dict], schemes: Mapping[str, dict[int, dict]], prefix: str = ""
) -> None:
    """Put scheme summaries into a policy's per-size fold metrics (`feasibility.schemes`)."""
    for name, per_size in schemes.items():
        for size, summary in per_size.items():
            entry = metrics.setdefault(size, {"assemblies": summary["assemblies"]})
            entry.setdefault("feasibility", {}).setdefault("schemes", {})[prefix + name] = summary


def _mean_curve(curves: Sequence[dict]) -> dict[str, list[float]]:
    """Vertical average of ROC curves: mean TPR at fixed FPRs (each curve a step function)."""
    tprs = []
    for curve in curves:
        fpr, tpr = np.asarray(curve["fpr"]), np.asarray(curve["tpr"])
        # the highest TPR reached at FPR ≤ x, for every x of the grid
        index = np.searchsorted(fpr, ROC_GRID, side="right") - 1
        tprs.append(np.maximum.accumulate(tpr)[index])
    return {"fpr": ROC_GRID.tolist(), "tpr": np.mean(tprs, axis=0).tolist()}


def feasibility_report(per_fold: Sequence[Mapping[int, dict]]) -> dict:
    """feasibility.json: per size and scheme the fold mean ± std of ROC AUC and of TPR at
    FPR ≤ MAX_FPR, the number of folds that defined them and the fold-mean ROC curve."""
    out: dict[str, dict] = {}
    sizes = sorted({size for fold in per_fold for size in fold})
    for size in sizes:
        folds = [fold[size]["feasibility"]["schemes"] for fold in per_fold if size in fold]
        names = list(dict.fromkeys(name for fold in folds for name in fold))
        entry = {}
        for name in names:
            summaries = [fold[name] for fold in folds if name in fold]
            curves = [s["roc"] for s in summaries if s["roc"] is not None]
            auc = mean_std([s["roc_auc"] for s in summaries])
            if auc is None:
                continue
            entry[name] = {
                "roc_auc": plain(auc),
                "tpr_at_fpr": plain(mean_std([s["tpr_at_fpr"] for s in summaries])),
                "folds": len(curves),
                "assemblies": sum(s["assemblies"] for s in summaries),
                "feasible": sum(s["feasible"] for s in summaries),
                "roc": _mean_curve(curves),
            }
        if entry:
            out[str(size)] = entry
    return {"max_fpr": MAX_FPR, "per_size": out}
