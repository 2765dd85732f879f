"""results.json and results.md: fold metrics aggregated as mean ± std, in the paper's layout.

Schema (issue 4): sizes are string keys; a metric undefined for a size (no fold defined it) is
absent, never zero. Besides the required keys each size also carries counts that keep the
numbers honest: `assemblies`; `forward_passes` (states scored, ≤ 2^N − 1 per assembly);
per-k `assemblies` and `empty` (assemblies counted for P@k and how many of those had no complete
sequence, which the empty-retrieval rule scores as 1); `no_sequence` (feasible assemblies with no
complete sequence at λ = 0.5) and the feasibility confusion.
std is the population standard deviation over folds (ddof = 0).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from grace.data.atomic import write_text_atomic

METRIC_ROWS = (
    ("Step-by-Step AUC", ("step_auc",)),
    ("Complete Sequence AUC", ("seq_auc",)),
    ("P@1", ("p_at_k", "1")),
    ("P@2", ("p_at_k", "2")),
    ("P@3", ("p_at_k", "3")),
    ("Feasibility ROC AUC", ("feasibility", "roc_auc")),
    ("Feasibility ROC AUC (classifier)", ("feasibility", "classifier_roc_auc")),
)


def mean_std(values: Sequence[float]) -> dict[str, float] | None:
    """{"mean", "std"} over the defined (non-NaN) values; None if there are none."""
    defined = [float(v) for v in values if v is not None and not math.isnan(v)]
    if not defined:
        return None
    return {"mean": float(np.mean(defined)), "std": float(np.std(defined))}


def _put(out: dict, key: str, value: Any) -> None:
    if value is not None:
        out[key] = value


def aggregate_size(folds: Sequence[dict]) -> dict:
    """Aggregate one size's fold summaries (from evaluation.evaluate.summarize)."""
    out: dict[str, Any] = {
        "folds": len(folds),
        "assemblies": sum(f["assemblies"] for f in folds),
        "forward_passes": sum(f["passes"] for f in folds),
    }
    _put(out, "step_auc", mean_std([f["step_auc"] for f in folds]))
    _put(out, "seq_auc", mean_std([f["seq_auc"] for f in folds]))
    p_at_k = {}
    for k in folds[0]["p_at_k"]:
        stat = mean_std([f["p_at_k"][k]["value"] for f in folds])
        if stat is not None:
            stat["assemblies"] = sum(f["p_at_k"][k]["assemblies"] for f in folds)
            stat["empty"] = sum(f["p_at_k"][k]["empty"] for f in folds)
            p_at_k[k] = stat
    _put(out, "p_at_k", p_at_k or None)
    out["no_sequence"] = sum(f["no_sequence"] for f in folds)
    feasibility: dict[str, Any] = {
        "confusion": {
            key: sum(f["feasibility"]["confusion"][key] for f in folds)
            for key in ("tp", "fp", "tn", "fn")
        }
    }
    _put(feasibility, "roc_auc", mean_std([f["feasibility"]["roc_auc"] for f in folds]))
    classifier = [f["feasibility"].get("classifier_roc_auc") for f in folds]
    _put(feasibility, "classifier_roc_auc", mean_std(classifier))
    out["feasibility"] = feasibility
    return out


def aggregate(per_fold: Sequence[dict[int, dict]]) -> dict[str, dict]:
    """{size: summary} per fold → {"size": aggregated}, sizes ascending as string keys."""
    sizes = sorted({size for fold in per_fold for size in fold})
    return {
        str(size): aggregate_size([fold[size] for fold in per_fold if size in fold])
        for size in sizes
    }


def lookup(entry: dict | None, path: Sequence[str]) -> dict | None:
    """`entry[path[0]][path[1]]…`, or None where a key is missing (an undefined metric)."""
    for key in path:
        if not isinstance(entry, dict) or key not in entry:
            return None
        entry = entry[key]
    return entry


def cell(stat: dict | None) -> str:
    """`0.97 ± 0.02`, or `–` for an undefined metric (as the paper prints it).

    A P@k cell also says how many counted assemblies had no complete sequence (each scores 1 by
    the empty-retrieval rule), e.g. `1.00 ± 0.00 (6/6 empty)`, so the number cannot flatter.
    """
    if stat is None:
        return "–"
    text = f"{stat['mean']:.2f} ± {stat['std']:.2f}"
    if stat.get("empty"):
        text += f" ({stat['empty']}/{stat['assemblies']} empty)"
    return text


OPTIONAL_ROWS = frozenset({"Feasibility ROC AUC (classifier)"})
"""Rows printed only where defined (runs without a classifier have none); the paper's rows always
print, with `–` for an undefined metric."""


def row_cells(label: str, stats: Sequence[dict | None]) -> list[str] | None:
    """The cells of one metric row; None for an optional row undefined in every column."""
    if label in OPTIONAL_ROWS and all(stat is None for stat in stats):
        return None
    return [cell(stat) for stat in stats]


def metrics_table(policies: dict[str, dict[str, dict]], sizes: Sequence[str]) -> str:
    """Markdown table: a row per (policy, metric), a column per test size (paper Table 2).

    An optional row (the classifier's) is left out where it is undefined for every size.
    """
    head = "| Policy | Metric | " + " | ".join(f"A{s}" for s in sizes) + " |"
    lines = [head, "|" + " --- |" * (len(sizes) + 2)]
    for policy, per_size in policies.items():
        for label, path in METRIC_ROWS:
            cells = row_cells(label, [lookup(per_size.get(s, {}), path) for s in sizes])
            if cells is not None:
                lines.append(f"| {policy} | {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def counts_table(per_size: dict[str, dict], sizes: Sequence[str]) -> str:
    """Counts behind the table: test assemblies, P@k denominators and empty retrievals."""
    head = "| Count (all folds) | " + " | ".join(f"A{s}" for s in sizes) + " |"
    lines = [head, "|" + " --- |" * (len(sizes) + 1)]

    def row(label: str, get) -> None:
        values = [get(per_size[s]) if s in per_size else None for s in sizes]
        lines.append(
            f"| {label} | " + " | ".join("–" if v is None else str(v) for v in values) + " |"
        )

    row("test assemblies", lambda e: e["assemblies"])
    row("feasible, no sequence at λ=0.5", lambda e: e["no_sequence"])
    for k in ("1", "2", "3"):
        row(f"P@{k} counted / empty", lambda e, k=k: _pk_count(e, k))
    row(
        "feasibility tp/fp/tn/fn",
        lambda e: "/".join(
            str(e["feasibility"]["confusion"][key]) for key in ("tp", "fp", "tn", "fn")
        ),
    )
    return "\n".join(lines)


def _pk_count(entry: dict, k: str) -> str | None:
    stat = lookup(entry, ("p_at_k", k))
    return None if stat is None else f"{stat['assemblies']} / {stat['empty']}"


def results_markdown(results: dict) -> str:
    """The human-readable results.md of one experiment run."""
    sizes = list(results["per_size"])
    policies = {"GRACE": results["per_size"]}
    policies.update({name: b["per_size"] for name, b in results["baselines"].items()})
    return (
        "\n\n".join(
            [
                f"# Results: protocol {results['protocol']}",
                f"Train sizes {results['train_sizes']}, test sizes {results['test_sizes']}, "
                f"{results['folds']}-fold cross-validation, mean ± std over folds, "
                f"{results['seconds']:.0f} s.",
                metrics_table(policies, sizes),
                "## Counts (GRACE)",
                counts_table(results["per_size"], sizes),
            ]
        )
        + "\n"
    )


def write_results(results: dict, out_dir: Path) -> None:
    """Write results.json and results.md into `out_dir` atomically."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out_dir / "results.json", json.dumps(results, indent=2) + "\n")
    write_text_atomic(out_dir / "results.md", results_markdown(results))
