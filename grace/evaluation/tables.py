"""Markdown tables of results: one writer, the metric rows and the cell format every table uses
(results.md, gather.md, the results book of task=report)."""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping, Sequence

from grace.evaluation.results import CountedStat, SizeSummary, Stat

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
    ("Step-by-Step AUC (off-path)", lambda e: e.step_auc_offpath),
    ("Step-by-Step AUC", lambda e: e.step_auc),
    ("Complete Sequence AUC", lambda e: e.seq_auc),
    ("P@1 (paper: empty = 1)", p_at_k(1, strict=False)),
    ("P@2 (paper: empty = 1)", p_at_k(2, strict=False)),
    ("P@3 (paper: empty = 1)", p_at_k(3, strict=False)),
    ("Feasibility ROC AUC (best sequence)", scheme_auc("best_sequence")),
    ("Feasibility ROC AUC (bottleneck)", scheme_auc("bottleneck")),
)
"""Rows of the results tables, strict figures first (label, metric)."""


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
