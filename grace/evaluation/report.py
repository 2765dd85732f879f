"""results.json and results.md: fold metrics aggregated as mean ± std, in the paper's layout.

The fields of results.json are the records of grace/evaluation/results.py (schema:
docs/results-schema.json). results.md leads with the strict figures, then the paper's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from grace.data.atomic import write_text_atomic
from grace.evaluation.results import (
    RESULTS,
    RESULTS_FILE,
    Confusion,
    CountedStat,
    ExperimentResults,
    FeasibilitySummary,
    FoldHealth,
    SchemeSummary,
    SizeSummary,
    Stat,
    to_json,
)
from grace.evaluation.tables import cell, markdown_table, metrics_table, p_at_k


def mean_std(values: Sequence[float | None]) -> Stat | None:
    """Mean and std over the defined (non-NaN) values; None if there are none."""
    defined = [float(v) for v in values if v is not None and not math.isnan(v)]
    if not defined:
        return None
    return Stat(mean=float(np.mean(defined)), std=float(np.std(defined)))


def _p_at_k(folds: Sequence[dict], key: str) -> dict[str, CountedStat] | None:
    out = {}
    for k in folds[0].get(key, {}):
        stat = mean_std([f[key][k]["value"] for f in folds])
        if stat is not None:
            out[k] = CountedStat(
                mean=stat.mean,
                std=stat.std,
                assemblies=sum(f[key][k]["assemblies"] for f in folds),
                empty=sum(f[key][k]["empty"] for f in folds),
            )
    return out or None


def _schemes(folds: Sequence[dict]) -> dict[str, SchemeSummary] | None:
    per_fold = [f["feasibility"].get("schemes", {}) for f in folds]
    out = {}
    for name in dict.fromkeys(n for schemes in per_fold for n in schemes):
        summaries = [schemes[name] for schemes in per_fold if name in schemes]
        auc = mean_std([x["roc_auc"] for x in summaries])
        if auc is not None:
            tpr = mean_std([x["tpr_at_fpr"] for x in summaries])
            out[name] = SchemeSummary(roc_auc=auc, tpr_at_fpr=tpr)
    return out or None


def aggregate_size(folds: Sequence[dict]) -> SizeSummary:
    """Aggregate one size's fold summaries (from evaluation.evaluate.summarize)."""
    confusion = {
        key: sum(f["feasibility"]["confusion"][key] for f in folds)
        for key in ("tp", "fp", "tn", "fn")
    }
    return SizeSummary(
        folds=len(folds),
        assemblies=sum(f["assemblies"] for f in folds),
        forward_passes=sum(f["passes"] for f in folds),
        step_auc=mean_std([f["step_auc"] for f in folds]),
        step_auc_offpath=mean_std([f["step_auc_offpath"] for f in folds]),
        offpath_states=sum(f["offpath_states"] for f in folds),
        seq_auc=mean_std([f["seq_auc"] for f in folds]),
        p_at_k=_p_at_k(folds, "p_at_k"),
        p_at_k_strict=_p_at_k(folds, "p_at_k_strict"),
        no_sequence=sum(f["no_sequence"] for f in folds),
        feasibility=FeasibilitySummary(confusion=Confusion(**confusion), schemes=_schemes(folds)),
    )


def aggregate(per_fold: Sequence[dict[int, dict]]) -> dict[str, SizeSummary]:
    """{size: summary} per fold → {"size": aggregated}, sizes ascending as string keys."""
    sizes = sorted({size for fold in per_fold for size in fold})
    return {
        str(size): aggregate_size([fold[size] for fold in per_fold if size in fold])
        for size in sizes
    }


def counts_table(per_size: dict[str, SizeSummary], sizes: Sequence[str]) -> str:
    """Counts behind the table: test assemblies, P@k denominators and empty retrievals."""

    def row(label: str, get) -> list[str]:
        values = [get(per_size[s]) if s in per_size else None for s in sizes]
        return [label, *("–" if v is None else str(v) for v in values)]

    def counted(k: int):
        def get(entry: SizeSummary) -> str | None:
            stat = p_at_k(k, strict=False)(entry)
            return None if stat is None else f"{stat.assemblies} / {stat.empty}"

        return get

    def confusion(entry: SizeSummary) -> str:
        c = entry.feasibility.confusion
        return f"{c.tp}/{c.fp}/{c.tn}/{c.fn}"

    rows = [
        row("test assemblies", lambda e: e.assemblies),
        row("feasible, no sequence at λ=0.5", lambda e: e.no_sequence),
        row("off-path states (step AUC off-path)", lambda e: e.offpath_states),
        *(row(f"P@{k} counted / empty", counted(k)) for k in (1, 2, 3)),
        row("feasibility tp/fp/tn/fn", confusion),
    ]
    return markdown_table(["Count (all folds)", *(f"A{s}" for s in sizes)], rows)


def feasibility_table(per_size: dict[str, dict[str, SchemeSummary]], sizes: Sequence[str]) -> str:
    """A row per feasibility scheme: ROC AUC and TPR at FPR ≤ 0.05 per test size.

    `per_size[size]` maps scheme → its summary (results.json's `feasibility.schemes`, or
    feasibility.json's sizes).
    """
    names = list(dict.fromkeys(n for s in sizes for n in per_size.get(s, {})))
    rows = []
    for name in names:
        cells = []
        for s in sizes:
            entry = per_size.get(s, {}).get(name)
            if entry is None:
                cells.append("–")
            else:
                tpr = entry.tpr_at_fpr
                cells.append(
                    cell(entry.roc_auc) + " / " + ("–" if tpr is None else f"{tpr.mean:.2f}")
                )
        rows.append([name, *cells])
    return markdown_table(["Scheme", *(f"A{s} ROC AUC / TPR@FPR≤0.05" for s in sizes)], rows)


def health_lines(health: Sequence[FoldHealth]) -> str:
    """A line per fold: collapsed or not, why, and its step AUC against the floor per size."""
    lines = []
    for fold in health:
        sizes = ", ".join(
            f"A{s} {v.step_auc:.3f} (floor {v.floor:.3f})" for s, v in fold.sizes.items()
        )
        state = "**COLLAPSED**: " + "; ".join(fold.reasons) if fold.collapsed else "ok"
        model = f" ({fold.model})" if fold.model is not None else ""
        lines.append(f"- fold {fold.fold}{model}: {state}. Test step AUC {sizes}.")
    return "\n".join(lines)


def results_markdown(results: ExperimentResults) -> str:
    """The human-readable results.md of one experiment run: strict figures first."""
    sizes = list(results.per_size)
    parts = [
        f"# Results: protocol {results.protocol}",
        f"Train sizes {results.train_sizes}, test sizes {results.test_sizes}, "
        f"{results.folds}-fold cross-validation, mean ± std over folds, "
        f"{results.seconds:.0f} s. Rows lead with the strict figures (an empty retrieval "
        "counts 0; step AUC off the true orders), then the paper's; the baselines `constant` and "
        "`never` are floors (docs/metrics.md).",
    ]
    if results.collapsed_folds:
        parts.append(f"**Warning: folds {results.collapsed_folds} collapsed** (see Folds below).")
    parts += [
        metrics_table(results.policies(), [(f"A{s}", s) for s in sizes]),
        "## Counts (GRACE)",
        counts_table(results.per_size, sizes),
    ]
    schemes = {s: e.feasibility.schemes or {} for s, e in results.per_size.items()}
    if any(schemes.values()):
        parts += ["## Feasibility (GRACE)", feasibility_table(schemes, sizes)]
    if results.fold_health:
        parts += ["## Folds", health_lines(results.fold_health)]
    return "\n\n".join(parts) + "\n"


def write_results(results: ExperimentResults, out_dir: Path) -> None:
    """Write results.json and results.md into `out_dir` atomically."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out_dir / RESULTS_FILE, to_json(results, RESULTS))
    write_text_atomic(out_dir / "results.md", results_markdown(results))


def mean_curves(per_fold: list[dict[int, dict]]) -> dict[str, dict]:
    """Fold-mean PR curve per size (all folds share the λ grid, so points align)."""
    out = {}
    for size in sorted({s for fold in per_fold for s in fold}):
        curves = [f[size]["curve"] for f in per_fold if size in f and f[size]["curve"]["recall"]]
        if curves:
            out[str(size)] = {
                key: np.mean([c[key] for c in curves], axis=0).tolist()
                for key in ("recall", "precision")
            }
    return out
