"""Plan and measure one policy on test assemblies (SPEC §6–§7).

Every assembly's reachable states are scored once (λ = 0, ≤ 2^N − 1 forward passes) and every
metric reads that one table: the λ sweep counts sequences by dynamic programming, P@k runs the
best-first top-k search on the table, feasibility thresholds the bottleneck score.

Step-AUC test states: every non-complete state that lies on some ground-truth order, labelled
with its valid next parts, plus the empty state of each infeasible assembly (all labels 0, since
no first part leads to completion). All N part scores of a state count, placed parts as
negatives, as in the reference's per-node evaluation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grace.domain.sample import LabelledAssembly
from grace.evaluation.metrics import (
    LAMBDAS,
    feasibility_confusion,
    feasibility_roc,
    precision_at_k,
    sequence_auc,
    sequence_pr_curve,
    step_auc,
)
from grace.planning.counting import bottleneck, label_table, retrieval_counts
from grace.planning.sequences import Scorer, score_states
from grace.planning.topk import table_scores, top_k


@dataclass(eq=False)
class AssemblyEval:
    """What one assembly contributes to the metrics of its size."""

    size: int
    feasible: bool
    relevant: int
    retrieved: np.ndarray
    hits: np.ndarray
    step_scores: np.ndarray
    step_labels: np.ndarray
    topk_relevant: list[bool]
    feasibility_score: float
    passes: int


def evaluate_assembly(
    scorer: Scorer,
    sample: LabelledAssembly,
    lambdas: np.ndarray = LAMBDAS,
    k_max: int = 3,
    threshold: float = 0.5,
) -> AssemblyEval:
    """Score the assembly's states once and derive everything the metrics need."""
    n = sample.size
    scored = score_states(scorer, sample.assembly, threshold=0.0)
    retrieved, hits = retrieval_counts(scored, sample.truth, lambdas)
    states = sample.truth.order_states()
    valid = label_table(sample.truth)
    bits = np.int64(1) << np.arange(n, dtype=np.int64)
    best = top_k(table_scores(scored), n, k_max, threshold)
    relevant = [_is_order(r.sequence, valid) for r in best]
    return AssemblyEval(
        size=n,
        feasible=sample.truth.feasible,
        relevant=sample.truth.n_orders(),
        retrieved=retrieved,
        hits=hits,
        step_scores=scored.table[states],
        step_labels=(valid[states][:, None] & bits) != 0,
        topk_relevant=relevant,
        feasibility_score=bottleneck(scored),
        passes=scored.passes,
    )


def _is_order(sequence: Sequence[int], valid: np.ndarray) -> bool:
    state = 0
    for part in sequence:
        if not valid[state] >> part & 1:
            return False
        state |= 1 << part
    return True


def summarize(evals: Sequence[AssemblyEval], ks: Sequence[int] = (1, 2, 3)) -> dict:
    """Metrics of one fold on one size; undefined ones are NaN (the report drops them)."""
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
    _, _, roc_auc = feasibility_roc(is_feasible, [e.feasibility_score for e in evals])
    return {
        "assemblies": len(evals),
        "step_auc": step_auc(
            np.concatenate([e.step_scores.ravel() for e in evals]),
            np.concatenate([e.step_labels.ravel() for e in evals]),
        ),
        "seq_auc": sequence_auc(retrieved, hits, relevant),
        "p_at_k": {
            str(k): precision_at_k([e.topk_relevant for e in evals], [e.relevant for e in evals], k)
            for k in ks
        },
        "no_sequence": int((is_feasible & ~found).sum()),
        "feasibility": {
            "roc_auc": roc_auc,
            "confusion": feasibility_confusion(is_feasible, found),
        },
        "curve": {"recall": recall.tolist(), "precision": precision.tolist()},
        "passes": int(sum(e.passes for e in evals)),
    }


def evaluate_by_size(
    scorer: Scorer,
    samples: Sequence[LabelledAssembly],
    ks: Sequence[int] = (1, 2, 3),
    threshold: float = 0.5,
) -> dict[int, dict]:
    """{size: summarize(...)} of one policy on one fold's test assemblies."""
    by_size: dict[int, list[AssemblyEval]] = {}
    for sample in samples:
        evaluated = evaluate_assembly(scorer, sample, k_max=max(ks), threshold=threshold)
        by_size.setdefault(sample.size, []).append(evaluated)
    return {size: summarize(evals, ks) for size, evals in sorted(by_size.items())}
