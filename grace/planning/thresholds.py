"""Where Algorithm 1 cuts a state's branches: at the paper's absolute λ, relative to the
state's best score, or at λ with the states where nothing clears it lifted (`threshold=`,
docs/metrics.md).

The paper opens a branch for every unplaced part scoring at least λ (Algorithm 1). Scores whose
scale drifts with the assembly's size (docs/size-generalisation.md) then fall below λ on every
valid step of a large assembly and the planner retrieves nothing, though the valid parts still
score highest. The relative rule opens a branch for every part scoring at least λ times the best
unplaced part's score in that state, so it reads the ranking, not the scale. It is applied as a
transformation of the scores (each part's share of the state's best), so every metric of
docs/metrics.md, the λ sweep included, measures the planner that thresholds those shares.
Sharing out every state also reorders the sequences of an assembly that λ already plans; the
lifted rule changes only the states where no part clears λ, so those keep the paper's order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grace.planning.sequences import Scorer, unplaced


@dataclass(frozen=True)
class AbsoluteThreshold:
    """`threshold=absolute` (the paper's): a part opens a branch iff its score is at
    least λ; the scores are planned as they are."""

    def __call__(self, scorer: Scorer) -> Scorer:
        return scorer


def _best_unplaced(scores: np.ndarray, states: np.ndarray) -> tuple[np.ndarray, ...]:
    """`scores` as float64, which of them are unplaced parts, and each state's best unplaced
    score (a column): what every rule relative to the state's best reads."""
    scores = np.asarray(scores, dtype=np.float64)
    free = unplaced(states, scores.shape[1])
    return scores, free, np.where(free, scores, -np.inf).max(axis=1, keepdims=True)


def relative_scores(scores: np.ndarray, states: np.ndarray, floor: float) -> np.ndarray:
    """Each unplaced part's score divided by the best unplaced part's of its state, where the
    part scores at least `floor` and the best above 0; elsewhere (placed parts, parts below the
    floor) min(score, 0), below every λ > 0. A share ≥ λ is a score ≥ λ × the state's best."""
    scores, free, best = _best_unplaced(scores, states)
    kept = free & (scores >= floor) & (best > 0.0)
    share = np.divide(scores, best, out=np.zeros_like(scores), where=kept)
    return np.where(kept, share, np.minimum(scores, 0.0))


@dataclass(frozen=True)
class RelativeThreshold:
    """`threshold=relative` (not in the paper): a part opens a branch iff its score is at least
    λ times the best score of the state's unplaced parts, and at least `floor`.

    The floor keeps what the absolute rule says of a state where every part scores low: no
    branch, so a dead end stops the planner and an infeasible assembly can still retrieve
    nothing. Scores uniformly scaled by any factor plan the same (above the floor).
    """

    floor: float = 0.05

    def __call__(self, scorer: Scorer) -> Scorer:
        def relative(assembly, states):
            return relative_scores(scorer(assembly, states), np.asarray(states), self.floor)

        return relative


def lifted_scores(scores: np.ndarray, states: np.ndarray, level: float, floor: float) -> np.ndarray:
    """The unplaced parts' scores of each state whose best unplaced part scores below `level` but
    at least `floor`, scaled so that best scores exactly `level`; every other score unchanged."""
    scores, free, best = _best_unplaced(scores, states)
    weak = (best < level) & (best >= floor) & (best > 0.0)
    factor = np.divide(level, best, out=np.ones_like(best), where=weak)
    return np.where(free, scores * factor, scores)


@dataclass(frozen=True)
class LiftedThreshold:
    """`threshold=lifted` (the default; not in the paper): the paper's λ, except in a state where
    no unplaced part clears `level` (λ, task.threshold) while the best clears `floor`: there the
    scores are scaled so the best scores exactly `level`, and Algorithm 1 follows that part
    instead of stopping.

    An assembly whose every state has a part above λ plans exactly as under the paper's rule.
    Elsewhere the sequences λ retrieves keep their probabilities, and a sequence through a lifted
    state carries a factor of at most `level` (0.5) for that step, which may still outrank them
    when its other steps are confident. A state where everything scores below `floor` still
    stops the planner (a dead end, or an infeasible assembly, can still retrieve nothing).
    """

    level: float = 0.5
    floor: float = 0.05

    def __call__(self, scorer: Scorer) -> Scorer:
        def lifted(assembly, states):
            scores = scorer(assembly, states)
            return lifted_scores(scores, np.asarray(states), self.level, self.floor)

        return lifted
