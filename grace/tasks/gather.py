"""`python -m grace task=gather task.roots=[multirun/table2]`: combine runs into the paper's tables.

Reads every results.json under the given folders and writes gather.md and gather.json into the run
folder: Table 2 (intra-sized beside many-to-one, one column per test size; strict figures first,
as in results.md), Table 3 (one-to-many: a row per training size, with the strict P@1 beside the
paper's two AUCs). Runs that differ in anything but the protocol and its sizes (a model
variant, as in the ablation sweep) get their own block of rows, labelled by those overrides;
baselines appear as variants of their own.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from omegaconf import MISSING, DictConfig

from grace.data.atomic import write_text_atomic
from grace.errors import UserError
from grace.evaluation.report import METRIC_ROWS, cell, lookup
from grace.tasks.runner import TaskSettings

log = logging.getLogger(__name__)


@dataclass
class GatherSettings(TaskSettings):
    """Schema of `task=gather` (values in grace/conf/task/gather.yaml)."""

    roots: list[str] = MISSING


SIZE_KEYS = ("protocol", "test_size", "train_size")
"""Overrides that choose the protocol and its sizes, not a variant."""


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
        if key.lstrip("+~").split(".")[0] not in SIZE_KEYS:
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


def collect(paths: Iterable[Path]) -> dict:
    """Per variant: {"table2": {protocol: {size: entry}}, "table3": {train size: {size: entry}}}."""
    runs = [json.loads(Path(path).read_text()) for path in paths]
    table2: dict[str, dict] = {}
    table3: dict[str, dict] = {}
    for results, label in zip(runs, variants(runs), strict=True):
        policies = {label: results["per_size"]}
        for name, baseline in results.get("baselines", {}).items():
            policies[name] = baseline["per_size"]
        protocol = results["protocol"]
        for name, per_size in policies.items():
            if protocol == "one_to_many":
                train = "+".join(str(s) for s in results["train_sizes"])
                table3.setdefault(name, {}).setdefault(train, {}).update(per_size)
            else:
                table2.setdefault(name, {}).setdefault(protocol, {}).update(per_size)
    return {"table2": table2, "table3": table3}


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
    parts = [f"# Gathered results ({n_runs} runs, mean ± std over folds)"]
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
    write_text_atomic(out_dir / "gather.json", json.dumps(tables, indent=2) + "\n")
    markdown = gather_markdown(tables, len(paths))
    write_text_atomic(out_dir / "gather.md", markdown)
    print(markdown)
    log.info("gathered %d runs into %s", len(paths), out_dir)
