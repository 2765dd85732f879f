"""Markdown tables of results: one writer, the metric rows and the cell format every table uses
(results.md, gather.md, the results book of task=report)."""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping, Sequence
from typing import Any

from grace.evaluation.results import CountedStat, SizeSummary, Stat
from grace.evaluation.size_scores import QUANTILES

Metric = Callable[[SizeSummary], Stat | None]
"""Where a metric sits in a size's entry (None: undefined)."""


def p_at_k(k: int, strict: bool) -> Metric:
    """P@k of an entry, strict (an empty retrieval counts 0) or the paper's (counts 1)."""

    def get(entry: SizeSummary) -> CountedStat | None:
        return ((entry.p_at_k_strict if strict else entry.p_at_k) or {}).get(str(k))

    return get


def scheme_auc(name: str) -> Metric:
    """ROC AUC of a feasibility scheme of an entry."""

    def get(entry: SizeSummary) -> Stat | None:
        scheme = (entry.feasibility.schemes or {}).get(name)
        return None if scheme is None else scheme.roc_auc

    return get


METRIC_ROWS: tuple[tuple[str, Metric], ...] = (
    ("P@1 (strict: empty = 0)", p_at_k(1, strict=True)),
    ("P@2 (strict: empty = 0)", p_at_k(2, strict=True)),
    ("P@3 (strict: empty = 0)", p_at_k(3, strict=True)),
    ("Complete Sequence AUC (strict: empty = 0)", lambda e: e.seq_auc_strict),
    ("Dead-end pass rate (lower is better)", lambda e: e.dead_end_pass_rate),
    ("Dead-end state leakage (lower is better)", lambda e: e.dead_end_leakage),
    ("Step-by-Step AUC", lambda e: e.step_auc),
    ("Placeable AUC off-path (physics recall)", lambda e: e.placeable_auc_offpath),
    ("Complete Sequence AUC (paper: empty = 1)", lambda e: e.seq_auc),
    ("P@1 (paper: empty = 1)", p_at_k(1, strict=False)),
    ("P@2 (paper: empty = 1)", p_at_k(2, strict=False)),
    ("P@3 (paper: empty = 1)", p_at_k(3, strict=False)),
    ("Feasibility ROC AUC (best sequence)", scheme_auc("best_sequence")),
    ("Feasibility ROC AUC (bottleneck)", scheme_auc("bottleneck")),
)
"""Rows of the results tables, strict figures and the dead-end rates first (label, metric)."""


def value(entry: SizeSummary | None, metric: Metric) -> Stat | CountedStat | None:
    """`metric` of `entry`, None where the entry or the metric is missing."""
    return None if entry is None else metric(entry)


def cell(stat: Stat | CountedStat | None) -> str:
    """`0.97 ± 0.02`, or `–` for an undefined metric (as the paper prints it).

    A P@k cell also says how many counted assemblies had no complete sequence (each scores 1 by
    the empty-retrieval rule), e.g. `1.00 ± 0.00 (6/6 empty)`, so the number cannot flatter.
    """
    if stat is None:
        return "–"
    text = f"{stat.mean:.2f} ± {stat.std:.2f}"
    if isinstance(stat, CountedStat) and stat.empty:
        text += f" ({stat.empty}/{stat.assemblies} empty)"
    return text


def markdown_table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A markdown table: the header cells, then one line per row."""
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def metrics_table(
    blocks: Mapping[str, Mapping[Hashable, SizeSummary]],
    columns: Sequence[tuple[str, Hashable]],
    first: str = "Policy",
    by_metric: bool = False,
) -> str:
    """A row per (block, metric of METRIC_ROWS), a column per (header, key into a block).

    Rows run block by block, or with `by_metric` metric by metric, every block's row of a metric
    beside the others' (GRACE's figure next to its floors'), leaving out a metric that no block
    defines in any column.
    """
    pairs = [(name, row) for name in blocks for row in METRIC_ROWS]
    if by_metric:
        defined = [
            row
            for row in METRIC_ROWS
            if any(
                value(b.get(key), row[1]) is not None for b in blocks.values() for _, key in columns
            )
        ]
        pairs = [(name, row) for row in defined for name in blocks]
    rows = [
        [name, label, *(cell(value(blocks[name].get(key), metric)) for _, key in columns)]
        for name, (label, metric) in pairs
    ]
    return markdown_table([first, "Metric", *(h for h, _ in columns)], rows)


def _share(value: float | None) -> str:
    return "–" if value is None else f"{value:.2f}"


def dataset_tables(stats: Mapping[str, object]) -> str:
    """The statistics `task=generate` writes (grace.data.stats.dataset_stats) as three markdown
    tables: per size, what rules decide the orders, what makes assemblies infeasible."""
    per_size: Mapping[str, Mapping] = stats["per_size"]  # type: ignore[assignment]
    seconds: Mapping[str, float] = stats.get("seconds_per_assembly") or {}  # type: ignore[assignment]
    sizes = list(per_size)
    head = ["size", "assemblies", "infeasible", "orders mean (median)", "≥ 3 orders"]
    head += ["robot-pruned", "non-local block", "checks: naive → run", "s per assembly"]
    rows = [
        [
            f"A{size}",
            str(s["assemblies"]),
            _share(s["infeasible_fraction"]),
            f"{s['orders_mean']:.1f} ({s['orders_median']:g})" if s["orders_mean"] else "–",
            _share(s["multi_order_fraction"]),
            _share(s["robot_pruned_fraction"]),
            _share(s["nonlocal_block_fraction"]),
            f"{s['naive_checks']:,} → {s['checks']:,}",
            f"{seconds[size]:.3f}" if size in seconds else "–",
        ]
        for size, s in per_size.items()
    ]
    tables = [markdown_table(head, rows)]
    for key, title in (
        ("rule_decisive_fraction", "rule decides"),
        ("infeasible_mechanisms", "mechanism"),
    ):
        names = list(dict.fromkeys(n for s in per_size.values() for n in s.get(key) or {}))
        body = [
            [name, *(_share((per_size[size].get(key) or {}).get(name)) for size in sizes)]
            for name in names
        ]
        tables.append(markdown_table([title, *(f"A{size}" for size in sizes)], body))
    return "\n\n".join(tables)


SCORE_GROUPS = (
    ("onpath", "valid", "valid parts, on the true orders"),
    ("onpath", "invalid", "invalid parts, on the true orders"),
    ("offpath", "valid", "valid parts, off them"),
    ("offpath", "invalid", "invalid parts, off them"),
)
"""The score groups of `task=size_diagnosis` (grace.evaluation.size_scores), as its rows."""

MEDIAN = QUANTILES.index(0.5)


def size_diagnosis_table(report: Mapping[str, Any]) -> str:
    """What `task=size_diagnosis` measured (its size_diagnosis.json) as one markdown table: per
    size, each score group's median / share at or above λ, then each activation term's mean;
    the last column is the largest size's value over the largest trained size's."""
    sizes = list(report["scores"])
    base = str(max(report["train_sizes"]))
    head = ["", *(f"A{s}" for s in sizes), f"A{sizes[-1]} ÷ A{base}"]
    rows = []
    for where, kind, label in SCORE_GROUPS:
        groups = [report["scores"][s][where][kind] for s in sizes]
        cells = [
            "–"
            if not g["count"]
            else f"{g['quantiles'][MEDIAN]:.2f} / {g['at_or_above_threshold']:.2f}"
            for g in groups
        ]
        rows.append([f"{label} (median / ≥ λ)", *cells, ""])
    terms = sorted({t for s in sizes for t in report["activations"][s]})
    for term in terms:
        means = [report["activations"][s].get(term, {}).get("mean") for s in sizes]
        top, ref = means[-1], report["activations"].get(base, {}).get(term, {}).get("mean")
        ratio = f"{top / ref:.2f}" if top is not None and ref else "–"
        rows.append([f"`{term}`", *(_share(m) for m in means), ratio])
    return markdown_table(head, rows)


INPUT_CONFLICT_ROWS = (
    ("test", "steps", "test steps", ",.0f"),
    ("test", "seen_in_training", "… with a training step of equal input", ",.0f"),
    ("test", "label_conflicts", "… of another label", ",.0f"),
    ("test", "ceiling", "Bayes ceiling on the test steps", ".4f"),
    ("test", "ceiling_on_conflicts", "… on those of another label", ".4f"),
    ("within", "steps", "all steps", ",.0f"),
    ("within", "shared_input", "… sharing their input", ",.0f"),
    ("within", "label_conflicts", "… of another label", ",.0f"),
    ("within", "ceiling", "Bayes ceiling on all steps", ".4f"),
    ("within", "ceiling_on_conflicts", "… on those of another label", ".4f"),
)
"""The rows of `task=input_conflicts`'s table: (part of the report, count, label, format)."""

MOVE_ROWS = (
    ("moved", "moved copies", ",.0f"),
    ("same_input", "… of the original's input", ",.0f"),
    ("feasibility_flips", "… of another feasibility", ",.0f"),
    ("steps", "steps compared", ",.0f"),
    ("label_changes", "… whose label the move changes", ",.0f"),
    ("ceiling", "Bayes ceiling on original and moved steps", ".4f"),
)
"""The rows of the moved copies (`task.moves`): (count, label, format)."""


def input_conflicts_table(report: Mapping[str, Any]) -> str:
    """What `task=input_conflicts` measured (its input_conflicts.json) as one markdown table:
    per size, the test steps against the training steps of their fold (summed over the folds),
    then all steps of the size against each other."""
    sizes = list(report["within"])
    rows = [
        [
            label,
            *("–" if s not in report[part] else format(report[part][s][key], fmt) for s in sizes),
        ]
        for part, key, label, fmt in INPUT_CONFLICT_ROWS
    ]
    distinct = [f"{report['distinct_inputs'][s]} / {report['assemblies'][s]}" for s in sizes]
    rows.append(["distinct inputs / assemblies", *distinct])
    moves = report.get("moves", {})
    for key, label, fmt in MOVE_ROWS if moves else ():
        rows.append(
            [label, *("–" if s not in moves else format(moves[s][key], fmt) for s in sizes)]
        )
    return markdown_table(["", *(f"A{s}" for s in sizes)], rows)
