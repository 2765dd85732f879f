"""Step scores by assembly size: what a policy gives valid and invalid parts, on and off the true
orders (docs/size-generalisation.md).

A network trained on small assemblies that plans larger ones badly can fail in two ways that the
AUCs alone do not tell apart: valid steps may fall below the threshold λ (empty retrievals), or
invalid steps may rise above it (wrong sequences). The distributions per size say which.

Valid parts are the positives of the two step AUCs (grace/evaluation/step_states.py): on the
true orders, the parts whose placement still lets the assembly complete; off them, the parts
whose placement the simulator accepts. Invalid parts are the other parts not yet placed (placed
parts are left out: their score is never asked for in planning).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from grace.domain.canonical import copy_groups
from grace.domain.sample import LabelledAssembly
from grace.evaluation.protocols import make_folds
from grace.evaluation.step_states import label_matrix, offpath_states, onpath_states
from grace.planning.sequences import Scorer

STATE_SETS = {"onpath": onpath_states, "offpath": offpath_states}
"""The two state sets of the step AUCs, by name."""

QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)


def held_out(samples: Sequence[LabelledAssembly], folds: int, seed: int, fold: int) -> list[int]:
    """Indices of the assemblies in fold `fold`'s own part, of every size: no model of that fold
    trained or early-stopped on them, whatever its protocol's sizes (grace/evaluation/protocols.py
    deals each size's assemblies to the folds before the sizes are chosen, every group of copies
    whole, as the experiment's folds do)."""
    sizes = [s.size for s in samples]
    return list(make_folds(sizes, sizes, sizes, folds, 0.0, seed, copy_groups(samples))[fold].test)


def step_scores(
    scorer: Scorer, samples: Sequence[LabelledAssembly]
) -> dict[str, dict[str, np.ndarray]]:
    """{state set: {"valid": scores, "invalid": scores}} over the states of `samples`."""
    out: dict[str, dict[str, list]] = {name: {"valid": [], "invalid": []} for name in STATE_SETS}
    for sample in samples:
        for name, states_of in STATE_SETS.items():
            states, masks = states_of(sample.truth)
            if len(states) == 0:
                continue
            scores = scorer(sample.assembly, states)
            valid = label_matrix(masks, sample.size)
            unplaced = ~label_matrix(states, sample.size)
            out[name]["valid"].append(scores[valid & unplaced])
            out[name]["invalid"].append(scores[~valid & unplaced])
    return {
        name: {kind: np.concatenate(v) if v else np.zeros(0) for kind, v in kinds.items()}
        for name, kinds in out.items()
    }


def summarise(scores: np.ndarray, threshold: float) -> dict[str, float | int | list[float]]:
    """Count, mean, quantiles (QUANTILES) and the share at or above λ of `scores`."""
    if scores.size == 0:
        return {"count": 0}
    return {
        "count": int(scores.size),
        "mean": float(scores.mean()),
        "quantiles": [float(q) for q in np.quantile(scores, QUANTILES)],
        "at_or_above_threshold": float((scores >= threshold).mean()),
    }
