"""Runs combined into the paper's tables: what task=gather and task=report read and pool.

Every results.json under the given folders is read (grace/evaluation/results.py): Table 2
(intra-sized beside many-to-one, one column per test size; strict figures first, as in
results.md), Table 3 (one-to-many: a row per training size, with the strict P@1 beside the
paper's two AUCs). Runs that differ in anything but the protocol and its sizes and how they ran
(threads, paths: the experiment's `run` keys, grace/roles.py) get their own block of rows (a
model variant, as in the ablation sweep), labelled by those overrides; baselines
appear as variants of their own, one per planning rule (`threshold=`, `task.threshold`) they
were planned under. A run re-planned from another's weights (`task.checkpoints`) is labelled
by its other overrides. Runs that differ only in `seed` (or `dataset.seed`) are
replicates, not variants: their cells pool them (mean ± std over the runs' fold means, counts
summed) and the block's label says how many seeds, e.g. the `seeds` sweep
(`python -m grace -m seed=0,1,2 dataset.seed=0`: training seeds on one data set) gathers into
one block.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grace.errors import UserError
from grace.evaluation.report import mean_std
from grace.evaluation.results import (
    RESULTS_FILE,
    CountedStat,
    ExperimentResults,
    SizeSummary,
    Stat,
    read_results,
)
from grace.evaluation.tables import cell, markdown_table, metrics_table, p_at_k, value

SIZE_KEYS = ("protocol", "test_size", "train_size")
"""Overrides that choose the protocol and its sizes, not a variant."""

REPLICATE_KEYS = ("seed", "dataset.seed")
"""Overrides that repeat a run rather than vary it: such runs are pooled."""

PLACE_KEYS = ("paths", "hydra")
"""Overrides that say where a run writes (paths.output_dir, hydra.run.dir), not a variant."""

WEIGHTS_SOURCE_KEYS = ("task.checkpoints",)
"""Overrides that say where a re-planned run's weights come from: a re-planned run is the
variant its other overrides say (e.g. `threshold=relative`), not a variant of its path."""

RULE_KEYS = ("threshold", "task.threshold")
"""Overrides (and their sub-keys) of the rule every policy of a run is planned under, the floors
included: a floor planned under another rule is another floor (docs/metrics.md)."""

TABLE3_PROTOCOLS = ("one_to_many", "upward")
"""The protocols of Table 3 (a row per training set: one size, or A3–A7 for `upward`, whose
test sizes A8–A12 extend its columns); the others fill Table 2."""


def find_results(
    roots: Iterable[str | Path], name: str = RESULTS_FILE, required: bool = True
) -> list[Path]:
    """Every file `name` (results.json) under the roots, sorted (a UserError if there is none
    and one is `required`)."""
    roots = [Path(root) for root in roots]
    found = []
    for root in roots:
        if not root.exists():
            raise UserError(
                f"task.roots: {root} does not exist; pass the sweep folder(s) holding the runs"
            )
        found += sorted(root.rglob(name))
    if not found and required:
        shown = [str(root) for root in roots]
        raise UserError(f"task.roots {shown}: no {name} found; run a sweep first")
    return found


def _replicate(results: ExperimentResults) -> tuple:
    """Which repeat a run is: its training seed and its data set's (absent in older runs)."""
    return (None, None) if results.run is None else (results.run.seed, results.run.data_seed)


def _under(key: str, prefixes: Collection[str]) -> bool:
    """Whether `key` is one of `prefixes` or a key below one (`planner.exhaustive_after` is
    under `planner`)."""
    parts = key.split(".")
    return any(".".join(parts[:n]) in prefixes for n in range(1, len(parts) + 1))


def _variant_overrides(
    results: ExperimentResults, run_keys: Collection[str] = ()
) -> dict[str, str]:
    """A run's overrides that may make it a variant: not its protocol and sizes, its place, its
    seeds, its weights' source, nor a `run_keys` key (or one below it)."""
    out = {}
    for override in [] if results.run is None else results.run.overrides:
        key, _, value_ = override.partition("=")
        key = key.lstrip("+~")
        if _under(key, run_keys) or key.split(".")[0] in SIZE_KEYS + PLACE_KEYS:
            continue
        if key not in REPLICATE_KEYS + WEIGHTS_SOURCE_KEYS:
            out[key] = value_
    return out


def _rule(results: ExperimentResults) -> str:
    """The planning rule's overrides of a run (RULE_KEYS), as a baseline's label suffix."""
    rule = [f"{k}={v}" for k, v in _variant_overrides(results).items() if _under(k, RULE_KEYS)]
    return f" ({' '.join(rule)})" if rule else ""


def variants(runs: list[ExperimentResults], run_keys: Collection[str] = ()) -> list[str]:
    """Label of each run: the overrides whose values differ between the gathered runs.

    Settings shared by every run (e.g. scale=paper), the protocol/size overrides and the keys
    that say how a run ran (`run_keys`: threads, paths; grace/roles.py) say nothing about which
    variant a row is; "GRACE" when nothing differs.
    """
    overrides = [_variant_overrides(r, run_keys) for r in runs]
    keys = sorted({k for o in overrides for k in o})
    varying = [k for k in keys if len({o.get(k) for o in overrides}) > 1]
    return [" ".join(f"{k}={o[k]}" for k in varying if k in o) or "GRACE" for o in overrides]


def pool(entries: list[Any]) -> Any:
    """Entries of runs that differ only in their seed, as one: a metric becomes the mean ± std
    over the runs' means with the number of `runs`; counts are summed; a metric that one run
    lacks is left out."""
    first = entries[0]
    if len(entries) == 1:
        return first
    if any(e is None for e in entries):
        return None
    if isinstance(first, Stat):
        stat = mean_std([e.mean for e in entries])
        pooled = Stat(mean=stat.mean, std=stat.std, runs=len(entries))
        if not isinstance(first, CountedStat):
            return pooled
        counts = {k: sum(getattr(e, k) for e in entries) for k in ("assemblies", "empty")}
        return CountedStat(**vars(pooled), **counts)
    if dataclasses.is_dataclass(first):
        return type(first)(
            **{
                f.name: pool([getattr(e, f.name) for e in entries])
                for f in dataclasses.fields(first)
            }
        )
    if isinstance(first, dict):
        keys = [k for k in first if all(k in e for e in entries)]
        pooled = {k: pool([e[k] for e in entries]) for k in keys}
        return {k: v for k, v in pooled.items() if v is not None} or None
    if all(isinstance(e, int) for e in entries):
        return sum(entries)
    return first


@dataclass
class Gathered:
    """The gathered runs: per variant (and baseline) label, Table 2's entries by protocol and
    test size, Table 3's by training sizes ("4" or "4+5") and test size; pooled over seeds."""

    table2: dict[str, dict[str, dict[str, SizeSummary]]] = field(default_factory=dict)
    table3: dict[str, dict[str, dict[str, SizeSummary]]] = field(default_factory=dict)
    runs: list[str] = field(default_factory=list)
    table3_protocols: list[str] = field(default_factory=list)
    """The protocols of Table 3's runs (TABLE3_PROTOCOLS order): its heading names them."""


def collect(paths: Iterable[Path], run_keys: Collection[str] = ()) -> Gathered:
    """The runs of `paths` (results.json files) pooled into Table 2 and Table 3 entries."""
    paths = list(paths)
    return gather_runs([read_results(path) for path in paths], paths, run_keys)


def gather_runs(
    runs: list[ExperimentResults], paths: list[Path], run_keys: Collection[str] = ()
) -> Gathered:
    """`runs` (read from `paths`) pooled into Table 2 and Table 3 entries; overrides of
    `run_keys` make no variant (see `variants`).

    A variant run with several seeds is labelled "<variant> (<n> seeds)", its entries pooled.
    """
    tables: dict[str, dict] = {"table2": {}, "table3": {}}
    seeds: dict[str, set] = {}
    table3_protocols = [p for p in TABLE3_PROTOCOLS if any(r.protocol == p for r in runs)]
    for results, label in zip(runs, variants(runs, run_keys), strict=True):
        rule = _rule(results)
        baselines = {f"{n}{rule}": b.per_size for n, b in results.baselines.items()}
        policies = {label: results.per_size} | baselines
        if results.protocol in TABLE3_PROTOCOLS:
            table, key = "table3", "+".join(str(s) for s in results.train_sizes)
        else:
            table, key = "table2", results.protocol
        seed = _replicate(results)
        for name, per_size in policies.items():
            seeds.setdefault(name, set()).add(seed)
            block = tables[table].setdefault(name, {}).setdefault(key, {})
            for size, entry in per_size.items():
                # One entry per seed: a baseline recurs unchanged in every variant's run.
                block.setdefault(size, {})[seed] = entry

    def label(name: str) -> str:
        n = len(seeds[name])
        return f"{name} ({n} seeds)" if n > 1 else name

    pooled = {
        table: {
            label(name): {
                key: {size: pool(list(by_seed.values())) for size, by_seed in block.items()}
                for key, block in by_key.items()
            }
            for name, by_key in by_name.items()
        }
        for table, by_name in tables.items()
    }
    return Gathered(
        pooled["table2"], pooled["table3"], [str(p.parent) for p in paths], table3_protocols
    )


def sizes_of(blocks: Iterable[dict]) -> list[str]:
    """The test sizes of `blocks` ({size: entry}), ascending."""
    return sorted({s for block in blocks for s in block}, key=int)


def table2_markdown(table2: dict[str, dict[str, dict[str, SizeSummary]]]) -> str:
    """Paper Table 2: metrics × (protocol, size), a block of rows per variant."""
    protocols = sorted({p for v in table2.values() for p in v}, key=lambda p: p != "intra")
    columns = [(p, s) for p in protocols for s in sizes_of(v.get(p, {}) for v in table2.values())]
    blocks = {
        name: {
            (p, s): entry for p, per_size in by_protocol.items() for s, entry in per_size.items()
        }
        for name, by_protocol in table2.items()
    }
    return metrics_table(blocks, [(f"{p} A{s}", (p, s)) for p, s in columns], first="Variant")


TABLE3_COLUMNS = (
    ("step", lambda e: e.step_auc),
    ("seq", lambda e: e.seq_auc),
    ("strict seq", lambda e: e.seq_auc_strict),
    ("strict P@1", p_at_k(1, strict=True)),
)
"""Paper Table 3's step and sequence AUC, then the strict sequence AUC and P@1 (an empty
retrieval counts 0)."""


def table3_markdown(table3: dict[str, dict[str, dict[str, SizeSummary]]]) -> str:
    """Paper Table 3: a row per training size; per test size the columns of TABLE3_COLUMNS."""
    sizes = sizes_of(block for v in table3.values() for block in v.values())
    columns = [(label, metric, s) for label, metric in TABLE3_COLUMNS for s in sizes]
    rows = []
    for name, by_train in table3.items():
        for train in sorted(by_train, key=lambda t: [int(x) for x in t.split("+")]):
            per_size = by_train[train]
            cells = [cell(value(per_size.get(s), metric)) for _, metric, s in columns]
            rows.append([name, f"A{train}", *cells])
    head = ["Variant", "Training set", *(f"{c[0]} A{c[2]}" for c in columns)]
    return markdown_table(head, rows)


def table3_metrics_markdown(table3: dict[str, dict[str, dict[str, SizeSummary]]]) -> str:
    """Table 3 with every metric of the intra table: a row per metric and (variant or floor,
    training set), strict figures first, each policy's row beside the floors' on the same test
    assemblies; a column per test size."""
    sizes = sizes_of(block for v in table3.values() for block in v.values())
    trains = sorted(
        {t for v in table3.values() for t in v}, key=lambda t: [int(x) for x in t.split("+")]
    )
    blocks = {
        f"{name} A{train}": table3[name][train]
        for train in trains
        for name in table3
        if train in table3[name]
    }
    return metrics_table(blocks, [(f"A{s}", s) for s in sizes], first="Policy", by_metric=True)


def gather_markdown(tables: Gathered) -> str:
    """gather.md: Table 2 and Table 3 of the gathered runs."""
    parts = [
        f"# Gathered results ({len(tables.runs)} runs; mean ± std over folds, or over the seeds' "
        "fold means in a block of several seeds)"
    ]
    if tables.table2:
        parts += ["## Table 2: intra-sized and many-to-one", table2_markdown(tables.table2)]
    if tables.table3:
        named = " and ".join(p.replace("_", "-") for p in tables.table3_protocols)
        parts += [f"## Table 3: {named}", table3_markdown(tables.table3)]
        parts += ["## Table 3, every metric", table3_metrics_markdown(tables.table3)]
    return "\n\n".join(parts) + "\n"
