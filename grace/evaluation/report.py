"""results.json and results.md: fold metrics aggregated as mean ± std, in the paper's layout.

Schema: sizes are string keys; a metric undefined for a size (no fold defined it) is absent,
never zero. Per size: `step_auc` (the paper's, on-path) and `step_auc_offpath` with the number of
`offpath_states`; `seq_auc`; `p_at_k` (the paper's empty-retrieval rule: an empty retrieval
scores 1) and `p_at_k_strict` (it scores 0), each per k with `assemblies` counted and how many of
them were `empty`; `no_sequence` (feasible assemblies with no complete sequence at λ = 0.5);
`feasibility` with its confusion counts and, per scheme (grace/evaluation/feasibility.py),
`roc_auc` and `tpr_at_fpr`; `assemblies` and `forward_passes` (states scored, ≤ 2^N − 1 per
assembly). Definitions in docs/metrics.md. std is the population standard deviation over folds
(ddof = 0). results.md leads with the strict figures, then the paper's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from grace.data.atomic import write_json_atomic, write_text_atomic

METRIC_ROWS = (
    ("P@1 (strict: empty = 0)", ("p_at_k_strict", "1")),
    ("P@2 (strict: empty = 0)", ("p_at_k_strict", "2")),
    ("P@3 (strict: empty = 0)", ("p_at_k_strict", "3")),
    ("Step-by-Step AUC (off-path)", ("step_auc_offpath",)),
    ("Step-by-Step AUC", ("step_auc",)),
    ("Complete Sequence AUC", ("seq_auc",)),
    ("P@1 (paper: empty = 1)", ("p_at_k", "1")),
    ("P@2 (paper: empty = 1)", ("p_at_k", "2")),
    ("P@3 (paper: empty = 1)", ("p_at_k", "3")),
    ("Feasibility ROC AUC (best sequence)", ("feasibility", "schemes", "best_sequence", "roc_auc")),
    ("Feasibility ROC AUC (bottleneck)", ("feasibility", "schemes", "bottleneck", "roc_auc")),
)
"""Rows of the results table, strict figures first (label, path into a size's entry)."""


def mean_std(values: Sequence[float]) -> dict[str, float] | None:
    """{"mean", "std"} over the defined (non-NaN) values; None if there are none."""
    defined = [float(v) for v in values if v is not None and not math.isnan(v)]
    if not defined:
        return None
    return {"mean": float(np.mean(defined)), "std": float(np.std(defined))}


def _put(out: dict, key: str, value: Any) -> None:
    if value is not None:
        out[key] = value


def _p_at_k(folds: Sequence[dict], key: str) -> dict | None:
    out = {}
    for k in folds[0].get(key, {}):
        stat = mean_std([f[key][k]["value"] for f in folds])
        if stat is not None:
            stat["assemblies"] = sum(f[key][k]["assemblies"] for f in folds)
            stat["empty"] = sum(f[key][k]["empty"] for f in folds)
            out[k] = stat
    return out or None


def _schemes(folds: Sequence[dict]) -> dict | None:
    per_fold = [f["feasibility"].get("schemes", {}) for f in folds]
    out = {}
    for name in dict.fromkeys(n for schemes in per_fold for n in schemes):
        summaries = [schemes[name] for schemes in per_fold if name in schemes]
        auc = mean_std([x["roc_auc"] for x in summaries])
        if auc is not None:
            out[name] = {"roc_auc": auc}
            _put(out[name], "tpr_at_fpr", mean_std([x["tpr_at_fpr"] for x in summaries]))
    return out or None


def aggregate_size(folds: Sequence[dict]) -> dict:
    """Aggregate one size's fold summaries (from evaluation.evaluate.summarize)."""
    out: dict[str, Any] = {
        "folds": len(folds),
        "assemblies": sum(f["assemblies"] for f in folds),
        "forward_passes": sum(f["passes"] for f in folds),
    }
    _put(out, "step_auc", mean_std([f["step_auc"] for f in folds]))
    _put(out, "step_auc_offpath", mean_std([f["step_auc_offpath"] for f in folds]))
    out["offpath_states"] = sum(f["offpath_states"] for f in folds)
    _put(out, "seq_auc", mean_std([f["seq_auc"] for f in folds]))
    _put(out, "p_at_k", _p_at_k(folds, "p_at_k"))
    _put(out, "p_at_k_strict", _p_at_k(folds, "p_at_k_strict"))
    out["no_sequence"] = sum(f["no_sequence"] for f in folds)
    feasibility: dict[str, Any] = {
        "confusion": {
            key: sum(f["feasibility"]["confusion"][key] for f in folds)
            for key in ("tp", "fp", "tn", "fn")
        }
    }
    _put(feasibility, "schemes", _schemes(folds))
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


def metrics_table(policies: dict[str, dict[str, dict]], sizes: Sequence[str]) -> str:
    """Markdown table: a row per (policy, metric), a column per test size (paper Table 2)."""
    head = "| Policy | Metric | " + " | ".join(f"A{s}" for s in sizes) + " |"
    lines = [head, "|" + " --- |" * (len(sizes) + 2)]
    for policy, per_size in policies.items():
        for label, path in METRIC_ROWS:
            cells = [cell(lookup(per_size.get(s, {}), path)) for s in sizes]
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
    row("off-path states (step AUC off-path)", lambda e: e.get("offpath_states"))
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


def feasibility_table(per_size: dict[str, dict], sizes: Sequence[str]) -> str:
    """A row per feasibility scheme: ROC AUC and TPR at FPR ≤ 0.05 per test size.

    `per_size[size]` maps scheme → {"roc_auc": stat, "tpr_at_fpr": stat} (results.json's
    `feasibility.schemes`, or feasibility.json's sizes).
    """
    names = list(dict.fromkeys(n for s in sizes for n in per_size.get(s, {})))
    head = "| Scheme | " + " | ".join(f"A{s} ROC AUC / TPR@FPR≤0.05" for s in sizes) + " |"
    lines = [head, "|" + " --- |" * (len(sizes) + 1)]
    for name in names:
        cells = []
        for s in sizes:
            entry = per_size.get(s, {}).get(name)
            if entry is None:
                cells.append("–")
            else:
                tpr = entry.get("tpr_at_fpr")
                cells.append(
                    cell(entry["roc_auc"]) + " / " + ("–" if tpr is None else f"{tpr['mean']:.2f}")
                )
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def health_lines(health: Sequence[dict]) -> str:
    """A line per fold: collapsed or not, why, and its step AUC against the floor per size."""
    lines = []
    for fold in health:
        sizes = ", ".join(
            f"A{s} {v['step_auc']:.3f} (floor {v['floor']:.3f})" for s, v in fold["sizes"].items()
        )
        state = "**COLLAPSED**: " + "; ".join(fold["reasons"]) if fold["collapsed"] else "ok"
        model = f" ({fold['model']})" if "model" in fold else ""
        lines.append(f"- fold {fold['fold']}{model}: {state}. Test step AUC {sizes}.")
    return "\n".join(lines)


def results_markdown(results: dict) -> str:
    """The human-readable results.md of one experiment run: strict figures first."""
    sizes = list(results["per_size"])
    policies = {"GRACE": results["per_size"]}
    policies.update({name: b["per_size"] for name, b in results["baselines"].items()})
    parts = [
        f"# Results: protocol {results['protocol']}",
        f"Train sizes {results['train_sizes']}, test sizes {results['test_sizes']}, "
        f"{results['folds']}-fold cross-validation, mean ± std over folds, "
        f"{results['seconds']:.0f} s. Rows lead with the strict figures (an empty retrieval "
        "counts 0; step AUC off the true orders), then the paper's; the baselines `constant` and "
        "`never` are floors (docs/metrics.md).",
    ]
    collapsed = results.get("collapsed_folds")
    if collapsed:
        parts.append(f"**Warning: folds {collapsed} collapsed** (see Folds below).")
    parts += [
        metrics_table(policies, sizes),
        "## Counts (GRACE)",
        counts_table(results["per_size"], sizes),
    ]
    schemes = {
        s: lookup(e, ("feasibility", "schemes")) or {} for s, e in results["per_size"].items()
    }
    if any(schemes.values()):
        parts += ["## Feasibility (GRACE)", feasibility_table(schemes, sizes)]
    if results.get("fold_health"):
        parts += ["## Folds", health_lines(results["fold_health"])]
    return "\n\n".join(parts) + "\n"


def write_results(results: dict, out_dir: Path) -> None:
    """Write results.json and results.md into `out_dir` atomically."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out_dir / "results.json", results)
    write_text_atomic(out_dir / "results.md", results_markdown(results))
