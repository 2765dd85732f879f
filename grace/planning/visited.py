"""The states Algorithm 1 visits that a training set lacks, labelled from the ground truth: what
one DAgger round adds to training (grace/cli/dagger_fit.py, docs/training.md)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from grace.domain.sample import LabelledAssembly
from grace.graphs.datamodule import state_masks, training_states
from grace.planning.sequences import Scorer, score_states


def visited_states(
    scorer: Scorer, samples: Sequence[LabelledAssembly], threshold: float, states: str
) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per sample index: the states Algorithm 1 scores at λ = `threshold` that the `states`
    training set lacks, with their ground-truth labels (only samples with any)."""
    extra = {}
    for i, sample in enumerate(samples):
        seen = score_states(scorer, sample.assembly, threshold).scored()
        new = np.setdiff1d(seen, training_states(sample, states)[0])
        if new.size:
            extra[i] = (new, state_masks(sample.truth, new)[0])
    return extra
