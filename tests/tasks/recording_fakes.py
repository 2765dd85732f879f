"""A policy for recording tests: the oracle of experiment_fakes, except that in the empty state it
prefers the first part that cannot start any feasible order (and has no preference off the
feasible orders), so its best sequence fails at step 0: a known failure."""

from __future__ import annotations

import numpy as np
from experiment_fakes import TRUTH, _puzzles

from grace.planning.counting import label_table


def wrong_first_part(name: str) -> int | None:
    """The part the policy wrongly starts `name` with, None if every part may start it."""
    first = TRUTH[name].label(0) if TRUTH[name].feasible else 0
    n = TRUTH[name].n_parts
    return next((p for p in range(n) if not first >> p & 1), None)


def make_scorer(noise):
    def scorer(assembly, states):
        if assembly.name not in TRUTH:
            _puzzles(int(assembly.name[1 : assembly.name.index("-")]))
        labels = label_table(TRUTH[assembly.name])[states]
        scores = 0.1 + 0.8 * ((labels[:, None] >> np.arange(assembly.n_parts)) & 1)
        scores[labels == 0] = 0.5  # off every feasible order: no preference
        wrong = wrong_first_part(assembly.name)
        if wrong is not None:
            scores[states == 0] = 0.01
            scores[states == 0, wrong] = 0.99
        return scores

    return scorer
