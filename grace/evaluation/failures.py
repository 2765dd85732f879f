"""Failure analysis in the style of the paper's Fig. 6 (Sec. V-C): where wrong sequences go wrong.

A wrongly retrieved sequence is a complete sequence Algorithm 1 returns at λ that is no ground-truth
order. Its first false step is the first step whose prefix is no prefix of a ground-truth order
(the step leaves the DAG of true orders). For each such step we keep its index (1-based), its
score and how many retrieved sequences it starts; counting by dynamic programme over the 2^N
states, never by listing sequences:

- `prefixes[s]`: retrieved prefixes that reach state s through valid steps only (all ≥ λ);
- `completions[s]`: complete paths from s whose every step scores ≥ λ;
- a false step from s with part p starts `prefixes[s] · completions[s ∪ {p}]` wrong sequences.

A wrong step whose branch dies in a dead end retrieves nothing and is not counted. Feasible and
infeasible assemblies are counted apart (FAILURE_KINDS).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import full_mask
from grace.domain.orders import GroundTruth
from grace.planning.counting import label_table, state_levels
from grace.planning.sequences import ScoredStates

SCORE_BINS = 10
"""Equal-width score bins between λ and 1 of the failure histogram."""
FAILURE_KINDS = {"feasible": True, "infeasible": False}
"""Kinds of assembly counted apart, by `truth.feasible`."""
"""Histograms are kept apart by assembly: on an infeasible one every retrieved sequence is wrong
from its first step (no state of it can complete), which says nothing about where planning on a
feasible assembly goes wrong."""


@dataclass(frozen=True)
class FalseStep:
    """A first false step: from `state` the planner places `part` (step `step`, 1-based)."""

    state: int
    part: int
    step: int
    score: float
    sequences: int


def first_false_steps(
    scored: ScoredStates, truth: GroundTruth, threshold: float
) -> list[FalseStep]:
    """Every first false step of the sequences Algorithm 1 retrieves at `threshold`."""
    n = scored.n_parts
    full = full_mask(n)
    table = scored.table
    passes = table >= threshold  # NaN (not scored) never passes
    levels = state_levels(n)
    completions = np.zeros(full + 1, dtype=np.int64)
    completions[full] = 1
    for level in reversed(levels[:-1]):
        go = passes[level.states[:, None], level.unplaced]
        completions[level.states] = (completions[level.children] * go).sum(axis=1)
    valid = label_table(truth)
    prefixes = np.zeros(full + 1, dtype=np.int64)
    prefixes[0] = 1
    out = []
    for level, above in itertools.pairwise(levels):
        states, parts = level.states[:, None], level.unplaced
        wrong = passes[states, parts] & (valid[states] >> parts & 1 == 0)
        counts = prefixes[states] * completions[level.children] * wrong
        rows, cols = np.nonzero(counts)
        for r, c in sorted(
            zip(rows.tolist(), cols.tolist(), strict=True), key=lambda rc: parts[rc]
        ):
            state, part = int(level.states[r]), int(parts[r, c])
            out.append(
                FalseStep(
                    state, part, state.bit_count() + 1, float(table[state, part]), int(counts[r, c])
                )
            )
        parents, placed = above.parents, above.placed
        good = passes[parents, placed] & (valid[parents] >> placed & 1 == 1)
        prefixes[above.states] = (prefixes[parents] * good).sum(axis=1)
    return out


def score_bins(threshold: float) -> np.ndarray:
    """Bin edges of the failure histogram: SCORE_BINS equal bins from λ to 1."""
    return np.linspace(threshold, 1.0, SCORE_BINS + 1)


def failure_histogram(steps: Sequence[FalseStep], threshold: float) -> dict:
    """{"bins", "by_step": {step: counts}} of first false steps, JSON-ready.

    Per step index: `sequences` (wrong sequences it starts), `false_steps` (distinct state–part
    pairs), `mean_score` (over sequences), and the score histograms weighted by sequences
    (`sequences_by_score`) and by distinct steps (`steps_by_score`).
    """
    edges = score_bins(threshold)
    by_step: dict[str, dict] = {}
    for index in sorted({s.step for s in steps}):
        chosen = [s for s in steps if s.step == index]
        scores = np.clip([s.score for s in chosen], edges[0], edges[-1])
        weights = np.array([s.sequences for s in chosen], dtype=float)
        by_step[str(index)] = {
            "sequences": int(weights.sum()),
            "false_steps": len(chosen),
            "mean_score": float(np.average(scores, weights=weights)),
            "sequences_by_score": np.histogram(scores, edges, weights=weights)[0]
            .astype(int)
            .tolist(),
            "steps_by_score": np.histogram(scores, edges)[0].tolist(),
        }
    return {"bins": edges.tolist(), "by_step": by_step}


def merge_histograms(histograms: Sequence[dict]) -> dict:
    """Sum failure histograms of the same bins (folds of one size); mean scores re-weighted."""
    bins = histograms[0]["bins"] if histograms else []
    by_step: dict[str, dict] = {}
    for hist in histograms:
        if hist["bins"] != bins:
            raise ValueError("merge_histograms: histograms with different score bins")
        for step, entry in hist["by_step"].items():
            into = by_step.setdefault(
                step,
                {
                    "sequences": 0,
                    "false_steps": 0,
                    "score_sum": 0.0,
                    "sequences_by_score": [0] * (len(bins) - 1),
                    "steps_by_score": [0] * (len(bins) - 1),
                },
            )
            into["sequences"] += entry["sequences"]
            into["false_steps"] += entry["false_steps"]
            into["score_sum"] += entry["mean_score"] * entry["sequences"]
            for key in ("sequences_by_score", "steps_by_score"):
                into[key] = [a + b for a, b in zip(into[key], entry[key], strict=True)]
    for entry in by_step.values():
        entry["mean_score"] = entry.pop("score_sum") / max(entry["sequences"], 1)
    ordered = {k: by_step[k] for k in sorted(by_step, key=int)}
    return {"bins": bins, "by_step": ordered}


def failures_report(per_fold: Sequence[dict[int, dict]]) -> dict:
    """failures.json: per size and kind of assembly (FAILURE_KINDS), the failure histograms of
    all folds summed, with the number of wrong sequences."""
    out = {}
    for size in sorted({size for fold in per_fold for size in fold}):
        entry = {}
        for kind in FAILURE_KINDS:
            hists = [fold[size]["failures"][kind] for fold in per_fold if size in fold]
            merged = merge_histograms(hists)
            merged["wrong_sequences"] = sum(e["sequences"] for e in merged["by_step"].values())
            entry[kind] = merged
        out[str(size)] = entry
    return {"per_size": out}
