"""Feasibility from mean-pooled GRACE part embeddings (SPEC §9, the paper's feasibility study).

The paper pools the part-node features of a trained GRACE over the parts of an assembly (empty
state) and fits off-the-shelf classifiers (linear SVM, RBF SVM, MLP, nearest neighbour) to tell
feasible from infeasible assemblies. The estimators are scikit-learn's, chosen in
`grace/conf/classifier/`; this module only builds the features and scores them per test size.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from sklearn.base import ClassifierMixin, clone

from grace.domain.sample import LabelledAssembly
from grace.evaluation.metrics import feasibility_roc
from grace.model.module import GraceModule
from grace.model.scoring import part_embeddings


def pooled_embeddings(module: GraceModule, samples: Sequence[LabelledAssembly]) -> np.ndarray:
    """(len(samples), hidden): the mean of the part features of each assembly's empty state."""
    return np.stack([part_embeddings(module, s.assembly).mean(axis=0) for s in samples])


def _feasibility_score(estimator: ClassifierMixin, x: np.ndarray) -> np.ndarray:
    if hasattr(estimator, "decision_function"):
        return np.asarray(estimator.decision_function(x), dtype=float)
    column = list(estimator.classes_).index(True)
    return np.asarray(estimator.predict_proba(x)[:, column], dtype=float)


def classifier_roc_auc(
    estimator: ClassifierMixin,
    module: GraceModule,
    train: Sequence[LabelledAssembly],
    test: Sequence[LabelledAssembly],
) -> dict[int, float]:
    """ROC AUC per test size of `estimator` fitted on the training assemblies' embeddings.

    NaN for every size when the training assemblies hold only one class (nothing to learn), and
    for a size whose test assemblies hold only one class (ROC undefined).
    """
    labels = np.array([s.truth.feasible for s in train])
    sizes = sorted({s.size for s in test})
    if labels.all() or not labels.any():
        return {size: float("nan") for size in sizes}
    fitted = clone(estimator).fit(pooled_embeddings(module, train), labels)
    scores = _feasibility_score(fitted, pooled_embeddings(module, test))
    out = {}
    for size in sizes:
        chosen = [i for i, s in enumerate(test) if s.size == size]
        feasible = np.array([test[i].truth.feasible for i in chosen])
        out[size] = feasibility_roc(feasible, scores[chosen])[2]
    return out
