"""Plan and measure one policy on test assemblies (paper, Algorithm 1 and Sec. V-A.2).

Every assembly's reachable states are scored once (λ = 0, ≤ 2^N − 1 forward passes) and every
metric reads that one table: the λ sweep counts sequences by dynamic programming, P@k runs the
best-first top-k search on the table (A*, guided by the exact completion bounds: without them a
policy of near-equal scores, the `constant` floor, makes plain best-first search expand every
prefix, N! at worst), the feasibility schemes read the best complete sequence,
the failure analysis counts first false steps.

The step metrics read the state sets of grace/evaluation/step_states.py: the paper's step AUC the
states on the ground-truth orders, the dead-end pass rate the feasible steps into dead ends from
those states, the off-path placeable AUC and the dead-end state leakage the states the planner
enters after a wrong step. In the AUCs all N part scores of a state count, placed parts as
negatives, as in the reference's per-node evaluation.
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grace.domain.sample import LabelledAssembly
from grace.evaluation.failures import (
    FAILURE_KINDS,
    FalseStep,
    failure_histogram,
    first_false_steps,
)
from grace.evaluation.feasibility_schemes import PLANNING_SCHEMES, planning_scores, scheme_summary
from grace.evaluation.metrics import (
    LAMBDAS,
    feasibility_confusion,
    pass_rate,
    precision_at_k,
    sequence_auc,
    sequence_pr_curve,
    state_leakage,
    step_auc,
)
from grace.evaluation.step_states import (
    dead_end_steps,
    label_matrix,
    offpath_states,
    onpath_states,
)
from grace.planning.counting import retrieval_counts
from grace.planning.sequences import ScoredStates, Scorer, score_states, unplaced
from grace.planning.topk import completion_bounds, table_scores, top_k


@dataclass(eq=False)
class AssemblyEval:
    """What one assembly contributes to the metrics of its size.

    `feasibility_scores` holds one score per planning scheme
    (grace/evaluation/feasibility_schemes.py): `sequences` (how many complete sequences
    Algorithm 1 retrieves at λ), `best_sequence` (probability of the most probable complete
    sequence), `bottleneck` (its best lowest step).
    """

    size: int
    feasible: bool
    relevant: int
    retrieved: np.ndarray
    hits: np.ndarray
    step_scores: np.ndarray
    step_labels: np.ndarray
    offpath_scores: np.ndarray
    offpath_labels: np.ndarray
    offpath_unplaced: np.ndarray
    dead_end_scores: np.ndarray
    topk_relevant: list[bool]
    feasibility_scores: dict[str, float]
    false_steps: list[FalseStep]
    passes: int


def evaluate_assembly(
    scorer: Scorer,
    sample: LabelledAssembly,
    lambdas: np.ndarray = LAMBDAS,
    k_max: int = 3,
    threshold: float = 0.5,
    tie_order: np.ndarray | None = None,
) -> AssemblyEval:
    """Score the assembly's states once and derive everything the metrics need; P@k breaks
    ties of equal probability by `tie_order` (grace.planning.topk.top_k)."""
    n = sample.size
    truth = sample.truth
    scored = score_states(scorer, sample.assembly, threshold=0.0)
    retrieved, hits = retrieval_counts(scored, truth, lambdas)
    on_states, on_masks = onpath_states(truth)
    off_states, off_masks = offpath_states(truth)
    dead_states, dead_masks = dead_end_steps(truth)
    table, extra = _step_table(scorer, sample, scored, np.concatenate([on_states, off_states]))
    bounds = completion_bounds(scored, threshold)
    best, _ = top_k(table_scores(scored), n, k_max, threshold, bounds, tie_order=tie_order)
    return AssemblyEval(
        size=n,
        feasible=truth.feasible,
        relevant=truth.n_orders(),
        retrieved=retrieved,
        hits=hits,
        step_scores=table[on_states],
        step_labels=label_matrix(on_masks, n),
        offpath_scores=table[off_states],
        offpath_labels=label_matrix(off_masks, n),
        offpath_unplaced=unplaced(off_states, n),
        dead_end_scores=table[dead_states][label_matrix(dead_masks, n)],
        topk_relevant=[truth.is_order(r.sequence) for r in best],
        feasibility_scores=planning_scores(scored, truth, threshold),
        false_steps=first_false_steps(scored, truth, threshold),
        passes=scored.passes + extra,
    )


def _step_table(
    scorer: Scorer, sample: LabelledAssembly, scored: ScoredStates, states: np.ndarray
) -> tuple[np.ndarray, int]:
    """The score table for the step AUCs, and how many extra states that cost: planning at λ = 0
    reaches every state unless a policy scores below 0 (the `never` floor). Those states are
    scored into a copy, so that planning metrics never see states the truth chose."""
    missing = np.unique(states[np.isnan(scored.table[states, 0])])
    if not missing.size:
        return scored.table, 0
    table = scored.table.copy()
    table[missing] = scorer(sample.assembly, missing)
    return table, int(missing.size)


def _pooled_step_auc(scores: Sequence[np.ndarray], labels: Sequence[np.ndarray]) -> float:
    return step_auc(
        np.concatenate([x.ravel() for x in scores]), np.concatenate([y.ravel() for y in labels])
    )


def summarize(
    evals: Sequence[AssemblyEval], ks: Sequence[int] = (1, 2, 3), threshold: float = 0.5
) -> dict:
    """Metrics of one fold on one size; undefined ones are NaN (the report drops them).

    `curve`, the feasibility schemes' `roc` and `failures` are per-fold material for the figures
    and side files; the report aggregates the rest.
    """
    feasible = [e for e in evals if e.relevant > 0]
    shape = (len(feasible), len(evals[0].retrieved))
    retrieved = np.array([e.retrieved for e in feasible]).reshape(shape)
    hits = np.array([e.hits for e in feasible]).reshape(shape)
    relevant = np.array([e.relevant for e in feasible])
    if feasible:
        recall, precision = sequence_pr_curve(retrieved, hits, relevant)
    else:
        recall, precision = np.zeros(0), np.zeros(0)
    is_feasible = np.array([e.feasible for e in evals])
    found = np.array([len(e.topk_relevant) > 0 for e in evals])
    schemes = {
        name: scheme_summary(is_feasible, [e.feasibility_scores[name] for e in evals])
        for name in PLANNING_SCHEMES
    }
    topk = [e.topk_relevant for e in evals]
    dead_end = np.concatenate([e.dead_end_scores for e in evals])
    n_relevant = [e.relevant for e in evals]
    return {
        "assemblies": len(evals),
        "step_auc": _pooled_step_auc(
            [e.step_scores for e in evals], [e.step_labels for e in evals]
        ),
        "placeable_auc_offpath": _pooled_step_auc(
            [e.offpath_scores for e in evals], [e.offpath_labels for e in evals]
        ),
        "offpath_states": int(sum(len(e.offpath_scores) for e in evals)),
        "dead_end_pass_rate": pass_rate(dead_end, threshold),
        "dead_end_steps": int(dead_end.size),
        "dead_end_leakage": state_leakage(
            np.concatenate([e.offpath_scores for e in evals]),
            np.concatenate([e.offpath_unplaced for e in evals]),
            threshold,
        ),
        "seq_auc": sequence_auc(retrieved, hits, relevant),
        "seq_auc_strict": sequence_auc(retrieved, hits, relevant, empty_precision=0.0),
        "p_at_k": {str(k): precision_at_k(topk, n_relevant, k) for k in ks},
        "p_at_k_strict": {str(k): precision_at_k(topk, n_relevant, k, empty_value=0.0) for k in ks},
        "no_sequence": int((is_feasible & ~found).sum()),
        "feasibility": {
            "roc_auc": schemes["bottleneck"]["roc_auc"],
            "confusion": feasibility_confusion(is_feasible, found),
            "schemes": schemes,
        },
        "curve": {"recall": recall.tolist(), "precision": precision.tolist()},
        "failures": {
            kind: failure_histogram(
                [s for e in evals if e.feasible == feasible for s in e.false_steps],
                threshold,
            )
            for kind, feasible in FAILURE_KINDS.items()
        },
        "passes": int(sum(e.passes for e in evals)),
    }


def tie_order(sample: LabelledAssembly, seed: int) -> np.ndarray:
    """A random rank per part, seeded by `seed` and the assembly's name: how P@k breaks ties
    of equal probability, so that a policy of tied scores (the `constant` floor) ranks a
    uniformly random order first rather than the part numbering's (docs/metrics.md)."""
    name = zlib.crc32(sample.assembly.name.encode())
    return np.random.default_rng([seed, sample.size, name]).permutation(sample.size)


def evaluate_by_size(
    scorer: Scorer,
    samples: Sequence[LabelledAssembly],
    ks: Sequence[int] = (1, 2, 3),
    threshold: float = 0.5,
    seed: int = 0,
) -> dict[int, dict]:
    """{size: summarize(...)} of one policy on one fold's test assemblies; `seed` seeds the
    tie-break of P@k (:func:`tie_order`)."""
    by_size: dict[int, list[AssemblyEval]] = {}
    for sample in samples:
        ties = tie_order(sample, seed)
        evaluated = evaluate_assembly(
            scorer, sample, k_max=max(ks), threshold=threshold, tie_order=ties
        )
        by_size.setdefault(sample.size, []).append(evaluated)
    return {size: summarize(evals, ks, threshold) for size, evals in sorted(by_size.items())}
