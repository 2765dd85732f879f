"""`python -m grace task=gather task.roots=[multirun/table2]`: combine runs into the paper's tables.

Reads every results.json under the given folders and writes gather.md and gather.json into the run
folder: Table 2 (intra-sized beside many-to-one, one column per test size; strict figures first,
as in results.md), Table 3 (one-to-many: a row per training size, with the strict P@1 beside the
paper's two AUCs). Runs that differ in anything but the protocol and its sizes (a model
variant, as in the ablation sweep) get their own block of rows, labelled by those overrides;
baselines appear as variants of their own. Runs that differ only in `seed` (or `dataset.seed`)
are replicates, not variants: their cells pool them (mean ± std over the runs' fold means,
counts summed) and the block's label says how many seeds, e.g. the `seeds` sweep
(`python -m grace -m seed=0,1,2 dataset.seed=0`: training seeds on one data set) gathers into
one block.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import MISSING, DictConfig

from grace.data.atomic import write_json_atomic, write_text_atomic
from grace.errors import UserError
from grace.evaluation.report import METRIC_ROWS, cell, lookup, mean_std
from grace.tasks.runner import TaskSettings

log = logging.getLogger(__name__)


@dataclass
class GatherSettings(TaskSettings):
    """Schema of `task=gather` (values in grace/conf/task/gather.yaml)."""

    roots: list[str] = MISSING


SIZE_KEYS = ("protocol", "test_size", "train_size")
"""Overrides that choose the protocol and its sizes, not a variant."""

REPLICATE_KEYS = ("seed", "dataset.seed")
"""Overrides that repeat a run rather than vary it: such runs are pooled."""


def _replicate(results: dict) -> tuple:
    """Which repeat a run is: its training seed and its data set's (absent in older runs)."""
    run = results.get("run", {})
    return run.get("seed"), run.get("data_seed")


def find_results(roots: Iterable[str | Path]) -> list[Path]:
    """Every results.json under the roots, sorted."""
    found = []
    for root in roots:
        root = Path(root)
        if not root.exists():
            raise UserError(
                f"task.roots: {root} does not exist; pass the sweep folder(s) holding the runs"
            )
        found += sorted(root.rglob("results.json"))
    return found


def _variant_overrides(results: dict) -> dict[str, str]:
    out = {}
    for override in results.get("run", {}).get("overrides", []):
        key, _, value = override.partition("=")
        key = key.lstrip("+~")
        if key.split(".")[0] not in SIZE_KEYS and key not in REPLICATE_KEYS:
            out[key] = value
    return out


def variants(runs: list[dict]) -> list[str]:
    """Label of each run: the overrides whose values differ between the gathered runs.

    Settings shared by every run (e.g. scale=paper) and the protocol/size overrides say nothing
    about which variant a row is; "GRACE" when nothing differs.
    """
    overrides = [_variant_overrides(r) for r in runs]
    keys = sorted({k for o in overrides for k in o})
    varying = [k for k in keys if len({o.get(k) for o in overrides}) > 1]
    return [" ".join(f"{k}={o[k]}" for k in varying if k in o) or "GRACE" for o in overrides]


def pool(entries: list[Any]) -> Any:
    """Entries of runs that differ only in their seed, as one: a metric ({"mean", "std"}) becomes
    the mean ± std over the runs' means with the number of `runs`; counts are summed."""
    first = entries[0]
    if len(entries) == 1:
        return first
    if isinstance(first, dict) and "mean" in first:
        stat = mean_std([e["mean"] for e in entries])
        if stat is None:
            return None
        stat["runs"] = len(entries)
        for count in ("assemblies", "empty"):
            if all(count in e for e in entries):
                stat[count] = sum(e[count] for e in entries)
        return stat
    if isinstance(first, dict):
        keys = [k for k in first if all(isinstance(e, dict) and k in e for e in entries)]
        pooled = {k: pool([e[k] for e in entries]) for k in keys}
        return {k: v for k, v in pooled.items() if v is not None}
    if all(isinstance(e, int) for e in entries):
        return sum(entries)
    return first


def collect(paths: Iterable[Path]) -> dict:
    """Per variant: {"table2": {protocol: {size: entry}}, "table3": {train size: {size: entry}}}.

    A variant run with several seeds is labelled "<variant> (<n> seeds)", its entries pooled.
    """
    runs = [json.loads(Path(path).read_text()) for path in paths]
    tables: dict[str, dict] = {"table2": {}, "table3": {}}
    seeds: dict[str, set] = {}
    for results, label in zip(runs, variants(runs), strict=True):
        policies = {label: results["per_size"]}
        for name, baseline in results.get("baselines", {}).items():
            policies[name] = baseline["per_size"]
        if results["protocol"] == "one_to_many":
            table, key = "table3", "+".join(str(s) for s in results["train_sizes"])
        else:
            table, key = "table2", results["protocol"]
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

    return {
        table: {
            label(name): {
                key: {size: pool(list(by_seed.values())) for size, by_seed in block.items()}
                for key, block in by_key.items()
            }
            for name, by_key in by_name.items()
        }
        for table, by_name in tables.items()
    }


def _sizes(blocks: Iterable[dict]) -> list[str]:
    return sorted({s for block in blocks for s in block}, key=int)


def table2_markdown(table2: dict) -> str:
    """Paper Table 2: metrics × (protocol, size), a block of rows per variant."""
    protocols = sorted({p for v in table2.values() for p in v}, key=lambda p: p != "intra")
    columns = [(p, s) for p in protocols for s in _sizes(v.get(p, {}) for v in table2.values())]
    head = "| Variant | Metric | " + " | ".join(f"{p} A{s}" for p, s in columns) + " |"
    lines = [head, "|" + " --- |" * (len(columns) + 2)]
    for name, by_protocol in table2.items():
        for label, path in METRIC_ROWS:
            cells = [cell(lookup(by_protocol.get(p, {}).get(s), path)) for p, s in columns]
            lines.append(f"| {name} | {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


TABLE3_COLUMNS = (
    ("step", ("step_auc",)),
    ("seq", ("seq_auc",)),
    ("strict P@1", ("p_at_k_strict", "1")),
)
"""Paper Table 3's step and sequence AUC, then the strict P@1 (an empty retrieval counts 0)."""


def table3_markdown(table3: dict) -> str:
    """Paper Table 3: a row per training size; per test size step AUC, sequence AUC, strict P@1."""
    sizes = _sizes(block for v in table3.values() for block in v.values())
    columns = [(label, path, s) for label, path in TABLE3_COLUMNS for s in sizes]
    head = "| Variant | Training set | " + " | ".join(f"{c[0]} A{c[2]}" for c in columns) + " |"
    lines = [head, "|" + " --- |" * (len(columns) + 2)]
    for name, by_train in table3.items():
        for train in sorted(by_train, key=lambda t: [int(x) for x in t.split("+")]):
            per_size = by_train[train]
            cells = [cell(lookup(per_size.get(s), path)) for _, path, s in columns]
            lines.append(f"| {name} | A{train} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def gather_markdown(tables: dict, n_runs: int) -> str:
    parts = [
        f"# Gathered results ({n_runs} runs; mean ± std over folds, or over the seeds' fold means "
        "in a block of several seeds)"
    ]
    if tables["table2"]:
        parts += ["## Table 2: intra-sized and many-to-one", table2_markdown(tables["table2"])]
    if tables["table3"]:
        parts += ["## Table 3: one-to-many", table3_markdown(tables["table3"])]
    return "\n\n".join(parts) + "\n"


def run(cfg: DictConfig) -> None:
    """Gather the runs under `cfg.task.roots` into gather.md and gather.json."""
    paths = find_results(cfg.task.roots)
    if not paths:
        raise UserError(
            f"task.roots {list(cfg.task.roots)}: no results.json found; run a sweep first"
        )
    tables = collect(paths)
    out_dir = Path(cfg.paths.output_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    tables["runs"] = [str(p.parent) for p in paths]
    write_json_atomic(out_dir / "gather.json", tables)
    markdown = gather_markdown(tables, len(paths))
    write_text_atomic(out_dir / "gather.md", markdown)
    print(markdown)
    log.info("gathered %d runs into %s", len(paths), out_dir)
