"""The results book (task=report): markdown tables of gathered runs, each table preceded by the
command lines that made its runs and the one that wrote it.

A run's command is rebuilt from what Hydra saved in its folder: the job's overrides
(`.hydra/overrides.yaml`), and from `.hydra/hydra.yaml` the config folder and name of a sweep
file (`--config-dir sweeps --config-name seeds`) and Hydra's own overrides (a launcher). Runs of
one sweep are written as one `-m` command when they are exactly the product of their overrides'
values, else one command per run. Tables: per protocol of Table 2 (intra-sized, many-to-one) a
row per metric and policy, strict figures first and every floor beside GRACE; Table 3
(one-to-many) as the paper lays it out; and, where several variants ran, a row per variant and
test size with the headline figures. Seeds are pooled as mean ± std (grace/evaluation/gather.py).
"""

from __future__ import annotations

import itertools
import shlex
from collections.abc import Collection, Sequence
from pathlib import Path

from omegaconf import OmegaConf

from grace.evaluation.gather import (
    TABLE3_PROTOCOLS,
    Gathered,
    gather_runs,
    sizes_of,
    table3_markdown,
)
from grace.evaluation.results import ExperimentResults, SizeSummary, hydra_overrides, read_results
from grace.evaluation.tables import cell, markdown_table, metrics_table, p_at_k, scheme_auc, value

ENTRY = ("python", "-m", "grace")
ROOT_CONFIG = "config"
"""The config `python -m grace` composes unless `--config-name` names another (a sweep file)."""
FLOORS = ("constant", "never")
"""Baselines that are floors: what a policy that knows nothing scores (docs/metrics.md)."""

TITLES = {
    "intra": "Intra-sized (paper Table 2, left)",
    "many_to_one": "Many-to-one (paper Table 2, right)",
    "one_to_many": "One-to-many (paper Table 3)",
    "upward": "Upward: trained on A3–A7, tested on A8–A12 (paper Table 3 extended)",
}

VARIANT_COLUMNS = (
    ("strict P@1", p_at_k(1, strict=True)),
    ("strict seq AUC", lambda e: e.seq_auc_strict),
    ("dead-end pass rate", lambda e: e.dead_end_pass_rate),
    ("dead-end leakage", lambda e: e.dead_end_leakage),
    ("step AUC", lambda e: e.step_auc),
    ("seq AUC", lambda e: e.seq_auc),
    ("paper P@1", p_at_k(1, strict=False)),
    ("feasibility ROC AUC (best seq.)", scheme_auc("best_sequence")),
)
"""The headline figures of a variant row, strict first."""

Command = tuple[tuple[str, ...], tuple[str, ...]]
"""(arguments before the overrides, the job's overrides) of one run."""


def run_command(run_dir: Path, results: ExperimentResults) -> Command:
    """The command line that made the run in `run_dir`, from Hydra's records there (the
    overrides in results.json where a run folder has none)."""
    records = run_dir / ".hydra"
    overrides = hydra_overrides(run_dir)
    if overrides is None:
        overrides = [] if results.run is None else list(results.run.overrides)
    prefix: list[str] = []
    if (records / "hydra.yaml").is_file():
        hydra = OmegaConf.load(records / "hydra.yaml").hydra
        cwd = Path(hydra.runtime.cwd)
        for source in hydra.runtime.config_sources:
            if source.provider == "command-line":
                path = Path(source.path)
                prefix += [
                    "--config-dir",
                    str(path.relative_to(cwd) if path.is_relative_to(cwd) else path),
                ]
        if hydra.job.config_name != ROOT_CONFIG:
            prefix += ["--config-name", str(hydra.job.config_name)]
        prefix += [
            str(o)
            for o in hydra.overrides.hydra
            if not str(o).startswith(("hydra.mode=", "hydra.run.dir="))
        ]
    return tuple(prefix), tuple(overrides)


def _sweep(prefix: tuple[str, ...], jobs: list[tuple[str, ...]]) -> list[str] | None:
    """One `-m` command for `jobs` if they are exactly the product of their overrides' values
    (every job the same keys, no value with a comma), else None."""
    split = [[o.split("=", 1) for o in job] for job in jobs]
    keys = [k for k, _ in split[0]]
    if any([k for k, _ in job] != keys or any("," in v for _, v in job) for job in split):
        return None
    values = [list(dict.fromkeys(job[i][1] for job in split)) for i in range(len(keys))]
    product = {
        tuple(f"{k}={v}" for k, v in zip(keys, combo, strict=True))
        for combo in itertools.product(*values)
    }
    if product != set(jobs):
        return None
    swept = [f"{k}={','.join(v)}" for k, v in zip(keys, values, strict=True)]
    return [shlex.join([*ENTRY, *prefix, "-m", *swept])]


def commands(runs: Sequence[Command]) -> list[str]:
    """The fewest command lines that make `runs`: one `-m` sweep per config where that is exact."""
    by_prefix: dict[tuple[str, ...], list[tuple[str, ...]]] = {}
    for prefix, overrides in runs:
        jobs = by_prefix.setdefault(prefix, [])
        if overrides not in jobs:
            jobs.append(overrides)
    lines = []
    for prefix, jobs in by_prefix.items():
        sweep = _sweep(prefix, jobs) if len(jobs) > 1 else None
        lines += sweep or [shlex.join([*ENTRY, *prefix, *job]) for job in jobs]
    return lines


def _policy_label(name: str) -> str:
    return f"{name} (floor)" if name.split(" (")[0] in FLOORS else name


def protocol_table(by_name: dict[str, dict[str, dict[str, SizeSummary]]], protocol: str) -> str:
    """A row per metric and policy (GRACE's variants, then the baselines), a column per test
    size: strict figures first, each beside its floors."""
    blocks = {_policy_label(n): v[protocol] for n, v in by_name.items() if protocol in v}
    sizes = sizes_of(blocks.values())
    return metrics_table(blocks, [(f"A{s}", s) for s in sizes], by_metric=True)


def variant_table(by_name: dict[str, dict[str, dict[str, SizeSummary]]], names: list[str]) -> str:
    """A row per variant and test size with the headline figures and the empty retrievals."""
    rows = []
    for name in names:
        for key, per_size in by_name[name].items():
            for size in sizes_of([per_size]):
                entry = per_size[size]
                figures = [cell(value(entry, metric)) for _, metric in VARIANT_COLUMNS]
                empty = f"{entry.no_sequence} / {entry.assemblies}"
                rows.append([name, key, f"A{size}", *figures, empty])
    head = ["Variant", "Protocol / training set", "Test size", *(c for c, _ in VARIANT_COLUMNS)]
    return markdown_table([*head, "feasible, no sequence / test assemblies"], rows)


def _block(title: str, run_lines: list[str], report_line: str, table: str) -> list[str]:
    shown = "\n".join(run_lines) if run_lines else "(no command recorded)"
    return [f"## {title}", f"```\n{shown}\n{report_line}\n```", table]


def results_book(paths: Sequence[Path], report_command: str, run_keys: Collection[str] = ()) -> str:
    """The results book of the runs whose results.json files are `paths`; overrides of
    `run_keys` make no variant (grace/evaluation/gather.py, `variants`)."""
    runs = [read_results(path) for path in paths]
    made = [run_command(Path(p).parent, r) for p, r in zip(paths, runs, strict=True)]
    baselines = {name for r in runs for name in r.baselines}
    parts = [
        "# Results book",
        f"{len(runs)} runs, mean ± std over folds (over the seeds' fold means where a row "
        "pools seeds). Strict figures first (an empty retrieval counts 0) and the dead-end rates "
        "(lower is better), then the paper's; `constant` and `never` are floors "
        "(docs/metrics.md). Each table follows the commands that made its runs and this book.",
    ]
    for protocol in sorted(
        {r.protocol for r in runs}, key=lambda p: (p in TABLE3_PROTOCOLS, p != "intra", p)
    ):
        chosen = [i for i, r in enumerate(runs) if r.protocol == protocol]
        gathered: Gathered = gather_runs(
            [runs[i] for i in chosen], [Path(paths[i]) for i in chosen], run_keys
        )
        run_lines = commands([made[i] for i in chosen])
        by_name = gathered.table3 if protocol in TABLE3_PROTOCOLS else gathered.table2
        names = [n for n in by_name if n.split(" (")[0] not in baselines]
        by_name = {n: by_name[n] for n in [*names, *(n for n in by_name if n not in names)]}
        if protocol in TABLE3_PROTOCOLS:
            table = table3_markdown({_policy_label(n): v for n, v in by_name.items()})
            parts += _block(TITLES[protocol], run_lines, report_command, table)
        else:
            table = protocol_table(by_name, protocol)
            parts += _block(TITLES.get(protocol, protocol), run_lines, report_command, table)
        if len(names) > 1:
            title = f"Variants: {TITLES.get(protocol, protocol)}"
            parts += _block(title, run_lines, report_command, variant_table(by_name, names))
    return "\n\n".join(parts) + "\n"
