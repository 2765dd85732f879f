"""Feasibility from mean-pooled GRACE part embeddings (paper, Sec. IV-C.4 scheme 2 and Fig. 5).

The paper pools the part-node features of a trained GRACE over the parts of an assembly (empty
state) and fits off-the-shelf classifiers (linear SVM, RBF SVM, MLP, nearest neighbour) to tell
feasible from infeasible assemblies. The estimators are scikit-learn's, chosen in
`grace/conf/classifier/`; this module only builds the features and the classifiers' scores.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from sklearn.base import ClassifierMixin, clone

from grace.domain.sample import LabelledAssembly
from grace.model.module import GraceModule
from grace.model.scoring import part_embeddings


def pooled_embeddings(module: GraceModule, samples: Sequence[LabelledAssembly]) -> np.ndarray:
    """(len(samples), hidden): the mean of the part features of each assembly's empty state."""
    return np.stack([part_embeddings(module, s.assembly).mean(axis=0) for s in samples])


def decision_scores(estimator: ClassifierMixin, x: np.ndarray) -> np.ndarray:
    """A fitted classifier's score for "feasible": its decision function, else P(feasible)."""
    if hasattr(estimator, "decision_function"):
        return np.asarray(estimator.decision_function(x), dtype=float)
    column = list(estimator.classes_).index(True)
    return np.asarray(estimator.predict_proba(x)[:, column], dtype=float)


def classifier_scores(
    estimator: ClassifierMixin, x_train: np.ndarray, feasible: np.ndarray, x_test: np.ndarray
) -> np.ndarray | None:
    """Feasibility scores of the test rows from a clone of `estimator` fitted on the training
    rows; None when the training rows hold only one class (nothing to learn)."""
    feasible = np.asarray(feasible, dtype=bool)
    if feasible.all() or not feasible.any():
        return None
    return decision_scores(clone(estimator).fit(x_train, feasible), x_test)
