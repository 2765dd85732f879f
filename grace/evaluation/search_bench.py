"""Planners side by side under one budget of simulator step checks (docs/planning.md).

Every planner gets a fresh `StepOracle` per assembly (the same per-(state, part) cache, cold),
and is charged its distinct step checks and its wall time, the cell queries its checks trigger
and the policy's forward passes included. A search is run once without a check budget: the
checks it had spent when its first verified order was complete decide its success at every
budget (a search is deterministic, so a budget only cuts it short). The summary per size:

- feasible assemblies: the share with a verified order within N, 2N, 5N, 20N checks and
  unlimited (N parts); the median and 90th percentile of checks and seconds to the first
  verified order (a planner that found none counts as ∞); the checks needed to reach a success
  rate of 50 / 90 / 99 %, and their ratio to the reference planner's (uninformed DFS);
- infeasible assemblies: the share proved infeasible, the checks and seconds it took, beside
  the brute force's (the ground truth's enumeration: every reachable (state, part) decided),
  and per assembly how many times fewer checks than the brute force the proof needed.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np

from grace.domain.assembly import Assembly
from grace.errors import UserError
from grace.evaluation.baselines import random_scorer
from grace.evaluation.tables import markdown_table
from grace.planning.search import Frontier, Outcome, SearchResult, VerifiedSearch
from grace.planning.sequences import Scorer
from grace.planning.step_checks import BlockerSteps, brute_force
from grace.planning.topk import rank_sequences

PLANNERS = ("grace", "grace_unverified", "heuristic", "dfs_blocks", "dfs", "brute_force")


SUCCESS_LEVELS = (0.5, 0.9, 0.99)
"""Success rates at which the checks each planner needs are compared."""

REFUSED = "refused"
"""Outcome of an unverified order that the simulator refuses at some step."""


@dataclass(frozen=True)
class PlannerRun:
    """One planner on one assembly: how it ended, and what it cost (checks, wall seconds) in
    all and until its first verified order (None without one)."""

    outcome: str
    checks: int
    seconds: float
    first_checks: int | None
    first_seconds: float | None
    expanded: int = 0

    @classmethod
    def of(cls, result: SearchResult) -> PlannerRun:
        return cls(
            str(result.outcome), result.checks, result.seconds, result.first_checks,
            result.first_seconds, result.expanded,
        )  # fmt: skip


Planner = Callable[[Assembly, BlockerSteps], PlannerRun]
"""`planner(assembly, oracle)`: plans one assembly with a fresh oracle (its time included)."""


def search_planner(search: VerifiedSearch, scorer: Scorer) -> Planner:
    """The verified search ordered by `scorer` (the network, a heuristic, random order)."""

    def run(assembly: Assembly, oracle: BlockerSteps) -> PlannerRun:
        clear = getattr(scorer, "clear", None)
        if clear is not None:
            clear()  # a cold start: the per-assembly embedding is part of the cost
        return PlannerRun.of(search.plan(scorer, assembly, oracle))

    return run


def unverified_planner(scorer: Scorer, max_expansions: int | None = None) -> Planner:
    """The network without verification: its most probable sequence, then checked step by
    step (the checks stop at the first refused step)."""

    def run(assembly: Assembly, oracle: BlockerSteps) -> PlannerRun:
        clear = getattr(scorer, "clear", None)
        if clear is not None:
            clear()
        start = time.perf_counter()
        ranking = rank_sequences(scorer, assembly, 1, max_expansions=max_expansions)
        if not ranking.ranked:
            seconds = time.perf_counter() - start
            return PlannerRun(str(Outcome.budget), 0, seconds, None, None, ranking.passes)
        state, outcome = 0, str(Outcome.verified)
        for part in ranking.ranked[0].sequence:
            if not oracle.check(state, part).feasible:
                outcome = REFUSED
                break
            state |= 1 << part
        seconds = time.perf_counter() - start
        found = outcome == str(Outcome.verified)
        return PlannerRun(
            outcome, oracle.checks, seconds, oracle.checks if found else None,
            seconds if found else None, ranking.passes,
        )  # fmt: skip

    return run


def brute_force_planner(assembly: Assembly, oracle: BlockerSteps) -> PlannerRun:
    """The ground truth's enumeration: every reachable (state, part) decided; its first order
    is known only once all are."""
    start = time.perf_counter()
    truth = brute_force(oracle)
    seconds = time.perf_counter() - start
    feasible = truth.feasible
    outcome = Outcome.verified if feasible else Outcome.infeasible
    return PlannerRun(
        str(outcome), truth.checks, seconds, truth.checks if feasible else None,
        seconds if feasible else None, len(truth.states),
    )  # fmt: skip


def run_planners(
    assembly: Assembly, planners: dict[str, Planner], oracle: Callable[[Assembly], BlockerSteps]
) -> dict[str, PlannerRun]:
    """Each planner on `assembly` with its own fresh oracle (its construction timed too)."""
    out = {}
    for name, planner in planners.items():
        start = time.perf_counter()
        fresh = oracle(assembly)
        setup = time.perf_counter() - start
        run = planner(assembly, fresh)
        first = None if run.first_seconds is None else run.first_seconds + setup
        out[name] = PlannerRun(
            run.outcome, run.checks, run.seconds + setup, run.first_checks, first, run.expanded
        )
    return out


@dataclass(frozen=True)
class AssemblyRuns:
    """All planners on one assembly; `feasible` and `truth_checks` from the ground truth
    (None for an assembly too large to label)."""

    name: str
    size: int
    feasible: bool | None
    truth_checks: int | None
    runs: dict[str, PlannerRun]

    def to_json(self) -> dict:
        return {**asdict(self), "runs": {k: asdict(v) for k, v in self.runs.items()}}


def _quantile(values: Sequence[float], q: float) -> float | None:
    """The q-quantile (lower) with ∞ for "never"; None if it is ∞."""
    if not values:
        return None
    ordered = sorted(values)
    value = ordered[min(len(ordered) - 1, max(0, int(np.ceil(q * len(ordered))) - 1))]
    return None if np.isinf(value) else float(value)


def _median(values: Sequence[float]) -> float | None:
    if not values:
        return None
    value = float(np.median(values))
    return None if np.isinf(value) else value


def _feasible_summary(
    records: list[AssemblyRuns], names: list[str], budgets: Sequence[int], reference: str | None
) -> dict:
    size = records[0].size
    out: dict = {"assemblies": len(records), "planners": {}}
    needs: dict[str, dict[str, float | None]] = {}
    for name in names:
        checks = [
            np.inf if r.runs[name].first_checks is None else r.runs[name].first_checks
            for r in records
        ]
        seconds = [
            np.inf if r.runs[name].first_seconds is None else r.runs[name].first_seconds
            for r in records
        ]
        success = {f"{b}N": float(np.mean([c <= b * size for c in checks])) for b in budgets}
        success["unlimited"] = float(np.mean(np.isfinite(checks)))
        needs[name] = {str(level): _quantile(checks, level) for level in SUCCESS_LEVELS}
        out["planners"][name] = {
            "success": success,
            "median_checks": _median(checks),
            "p90_checks": _quantile(checks, 0.9),
            "median_seconds": _median(seconds),
            "p90_seconds": _quantile(seconds, 0.9),
            "max_seconds": _quantile(seconds, 1.0),
            "checks_for_success": needs[name],
        }
    if reference in needs:
        for name in names:
            out["planners"][name]["checks_for_success_vs_reference"] = {
                level: (ref / mine if ref is not None and mine else None)
                for (level, ref), mine in zip(
                    needs[reference].items(), needs[name].values(), strict=True
                )
            }
    return out


def _infeasible_summary(records: list[AssemblyRuns], names: list[str]) -> dict:
    truth = [float(r.truth_checks) for r in records if r.truth_checks is not None]
    out: dict = {"assemblies": len(records), "planners": {}}
    if truth:
        out["brute_force_median_checks"] = _median(truth)
    for name in names:
        runs = [r.runs[name] for r in records]
        proved = [run.outcome == str(Outcome.infeasible) for run in runs]
        checks = [run.checks if ok else np.inf for run, ok in zip(runs, proved, strict=True)]
        seconds = [run.seconds if ok else np.inf for run, ok in zip(runs, proved, strict=True)]
        ratios = [  # a proof without a step check (grace/planning/precedence.py): ∞ fewer
            r.truth_checks / c if c else np.inf
            for r, c in zip(records, checks, strict=True)
            if r.truth_checks is not None
        ]
        slower = [  # seconds over the brute force's on the same assembly
            r.runs[name].seconds / r.runs["brute_force"].seconds
            for r in records
            if "brute_force" in r.runs and r.runs["brute_force"].seconds > 0
        ]
        out["planners"][name] = {
            "proved": float(np.mean(proved)),
            "max_seconds_vs_brute_force": max(slower) if slower else None,
            "median_checks": _median(checks),
            "median_seconds": _median(seconds),
            "p90_seconds": _quantile(seconds, 0.9),
            # brute-force checks / this planner's (0 where it proved nothing)
            "median_fewer_than_brute_force": _median(ratios) if ratios else None,
            "min_fewer_than_brute_force": min(ratios) if ratios else None,
            "share_fewer_checks_than_brute_force": float(np.mean([x > 1 for x in ratios]))
            if ratios
            else None,
        }
    return out


def _other_summary(records: list[AssemblyRuns], names: list[str]) -> dict:
    """Assemblies without a ground truth: how each planner ended and at what cost."""
    out: dict = {"assemblies": len(records), "planners": {}}
    for name in names:
        runs = [r.runs[name] for r in records]
        outcomes = sorted({run.outcome for run in runs})
        out["planners"][name] = {
            "outcomes": {o: sum(run.outcome == o for run in runs) for o in outcomes},
            "median_seconds": _median([run.seconds for run in runs]),
            "max_seconds": max(run.seconds for run in runs),
            "max_checks": max(run.checks for run in runs),
            "median_first_seconds": _median(
                [np.inf if run.first_seconds is None else run.first_seconds for run in runs]
            ),
        }
    return out


def summarise(
    records: list[AssemblyRuns], budgets: Sequence[int], reference: str | None
) -> dict[str, dict]:
    """Per size: the feasible, infeasible and unlabelled assemblies' figures (module
    docstring)."""
    out: dict[str, dict] = {}
    for size in sorted({r.size for r in records}):
        group = [r for r in records if r.size == size]
        names = list(group[0].runs)
        entry: dict = {}
        feasible = [r for r in group if r.feasible]
        infeasible = [r for r in group if r.feasible is False]
        unknown = [r for r in group if r.feasible is None]
        if feasible:
            entry["feasible"] = _feasible_summary(feasible, names, budgets, reference)
        if infeasible:
            entry["infeasible"] = _infeasible_summary(infeasible, names)
        if unknown:
            entry["unlabelled"] = _other_summary(unknown, names)
        out[str(size)] = entry
    return out


def planner_set(
    names: list[str],
    search: VerifiedSearch,
    scorer: Scorer,
    heuristic: Scorer,
    seed: int,
    max_expansions: int | None = None,
) -> dict[str, Planner]:
    """The planners of `names` (see the module docstring), all searches with `search`'s
    settings except where a baseline's definition says otherwise."""
    unknown = sorted(set(names) - set(PLANNERS))
    if unknown:
        raise UserError(f"task.planners has unknown planners {unknown}; fix: use {list(PLANNERS)}")
    dfs = replace(search, frontier=Frontier.greedy)
    make = {
        "grace": lambda: search_planner(search, scorer),
        "grace_unverified": lambda: unverified_planner(scorer, max_expansions),
        "heuristic": lambda: search_planner(search, heuristic),
        "dfs_blocks": lambda: search_planner(replace(dfs, learn_blocks=True), random_scorer(seed)),
        "dfs": lambda: search_planner(replace(dfs, learn_blocks=False), random_scorer(seed)),
        "brute_force": lambda: brute_force_planner,
    }
    return {name: make[name]() for name in names}


def summary_line(size: str, kind: str, name: str, figures: dict) -> str:
    """One printed line of the summary: a planner's figures on one size and kind."""
    if kind == "feasible":
        success = " ".join(f"{v:5.2f}" for v in figures["success"].values())
        checks, seconds = figures["median_checks"], figures["median_seconds"]
        med = f"{checks:7.0f}" if checks is not None else "      ∞"
        sec = f"{seconds:6.2f}" if seconds is not None else "     ∞"
        return f"A{size:<3} {kind:<10} {name:<17} {success}  {med} {sec}"
    checks, seconds = figures["median_checks"], figures["median_seconds"]
    ratio = figures["median_fewer_than_brute_force"]
    return (
        f"A{size:<3} {kind:<10} {name:<17} proved {figures['proved']:4.2f}  median "
        + (f"{checks:.0f} checks, {seconds:.2f} s" if checks is not None else "∞")
        + (f", {ratio:.1f}x fewer than brute force" if ratio else "")
    )


def _figure(value: float | None, digits: int = 0) -> str:
    return "∞" if value is None else f"{value:.{digits}f}"


def search_bench_markdown(summary: dict[str, dict]) -> str:
    """The summary as markdown (search_bench.md): per size, the feasible assemblies' success
    within each budget and median checks and seconds to the first verified order; the
    infeasible ones' proofs beside the brute force; the unlabelled ones' outcomes."""
    feasible, infeasible, unlabelled = [], [], []
    budgets: list[str] = []
    for size, entry in summary.items():
        if "feasible" in entry:
            group = entry["feasible"]
            for i, (name, f) in enumerate(group["planners"].items()):
                budgets = list(f["success"])
                label = f"A{size} ({group['assemblies']})" if i == 0 else ""
                rates = [f"{v:.2f}" for v in f["success"].values()]
                checks, seconds = f["median_checks"], f["median_seconds"]
                feasible.append(
                    [label, name, *rates, _figure(checks), _figure(seconds, 2)]
                )  # fmt: skip
        if "infeasible" in entry:
            group = entry["infeasible"]
            for i, (name, f) in enumerate(group["planners"].items()):
                label = f"A{size} ({group['assemblies']})" if i == 0 else ""
                ratio = f["median_fewer_than_brute_force"]
                slower = f.get("max_seconds_vs_brute_force")
                infeasible.append(
                    [label, name, f"{f['proved']:.2f}", _figure(f["median_checks"]),
                     _figure(f["median_seconds"], 2), _figure(ratio, 1),
                     "–" if slower is None else f"{slower:.2f}"]
                )  # fmt: skip
        for i, (name, f) in enumerate(entry.get("unlabelled", {}).get("planners", {}).items()):
            label = f"A{size} ({entry['unlabelled']['assemblies']})" if i == 0 else ""
            outcomes = ", ".join(f"{k} {v}" for k, v in f["outcomes"].items())
            unlabelled.append([label, name, outcomes, f"{f['max_seconds']:.2f}"])
    parts = []
    if feasible:
        head = ["size (feasible)", "planner", *budgets, "median checks", "median s"]
        parts.append(markdown_table(head, feasible))
    if infeasible:
        head = ["size (infeasible)", "planner", "proved", "median checks", "median s",
                "× fewer checks than brute force", "max s / brute force's s"]  # fmt: skip
        parts.append(markdown_table(head, infeasible))
    if unlabelled:
        parts.append(markdown_table(["size", "planner", "outcomes", "max s"], unlabelled))
    return "\n\n".join(parts) + "\n"
