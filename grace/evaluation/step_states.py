"""The two state sets the step AUCs read: on the ground-truth orders, and off them.

On-path (the paper's step AUC, Sec. V-A.2): every non-complete state on some ground-truth order,
labelled with its valid next parts (placing the part still allows completion); for an infeasible
assembly the empty state, all labels 0. These are the states the training orders describe.

Off-path (`step_auc_offpath`, docs/metrics.md): the states the planner enters after a wrong step.
Exactly: every non-complete state reachable from the empty one by physically feasible placements
(a state of the ground-truth DAG) from which no complete order exists, i.e. a dead end or a state
whose every feasible continuation ends in dead ends. Its label for a part is 1 iff placing that part
is feasible from there (the ground truth's `placeable` mask); "still completes" would be 0
everywhere. For an infeasible assembly every reachable state is off-path, the empty one included.
States no feasible placement reaches are not in the ground truth and have no labels, so they are
left out.
"""

from __future__ import annotations

import numpy as np

from grace.domain.assembly import full_mask
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.graphs.assembly_graph import state_flags
from grace.graphs.datamodule import StateSet, training_states
from grace.planning.sequences import Scorer


def onpath_states(truth: GroundTruth) -> tuple[np.ndarray, np.ndarray]:
    """(states, label masks) of the paper's step AUC: decision states of the true orders."""
    states = truth.order_states()
    return states, truth.completable[np.searchsorted(truth.states, states)]


def offpath_states(truth: GroundTruth) -> tuple[np.ndarray, np.ndarray]:
    """(states, label masks) of the off-path step AUC: reachable states from which no order
    completes, labelled with the parts whose placement is feasible there."""
    keep = (truth.completable == 0) & (truth.states != full_mask(truth.n_parts))
    return truth.states[keep].astype(np.int64), truth.placeable[keep]


def label_matrix(masks: np.ndarray, n_parts: int) -> np.ndarray:
    """Boolean (len(masks), N) labels from part bitmasks."""
    bits = np.int64(1) << np.arange(n_parts, dtype=np.int64)
    return (np.asarray(masks, dtype=np.int64)[:, None] & bits) != 0


def state_scores(scorer: Scorer, samples: list[LabelledAssembly]) -> tuple[np.ndarray, np.ndarray]:
    """Flat (scores, labels) over the step-AUC test states of `samples` (docs/metrics.md)."""
    scores, labels = [], []
    for sample in samples:
        s, y = training_states(sample, StateSet.orders)
        scores.append(scorer(sample.assembly, s).ravel())
        labels.append(state_flags(y, sample.size).numpy().ravel())
    if not scores:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(scores), np.concatenate(labels)
