"""Metrics of SPEC §7 as pure functions on arrays (no model or planner imports)."""

from __future__ import annotations

import numpy as np
from sklearn.metrics import auc, precision_recall_curve


def step_auc(scores: np.ndarray, labels: np.ndarray) -> float:
    """Step-by-step AUC: area under the precision–recall curve of part scores vs next-step labels.

    Undefined (NaN) when no label is positive.
    """
    labels = np.asarray(labels).ravel().astype(bool)
    if not labels.any():
        return float("nan")
    precision, recall, _ = precision_recall_curve(labels, np.asarray(scores).ravel())
    return float(auc(recall, precision))
