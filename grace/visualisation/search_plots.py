"""search_bench.png: success rate against the budget of simulator step checks, and the checks
that proofs of infeasibility took beside the brute force's (docs/planning.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from grace.visualisation.plots import save_figure


def search_bench_plot(summary: dict[str, dict], path: Path) -> None:
    """One panel per labelled size: the share of feasible assemblies with a verified order
    within each budget, one line per planner; a last panel: median checks to prove the
    infeasible ones infeasible per size (log scale; missing: some planner proved less than
    half), with the brute force's."""
    sizes = [s for s, entry in summary.items() if "feasible" in entry]
    fig = Figure(figsize=(3.2 * (len(sizes) + 1), 3.4), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(sizes) + 1))
    for ax, size in zip(axes, sizes, strict=False):
        planners = summary[size]["feasible"]["planners"]
        for name, figures in planners.items():
            labels = list(figures["success"])
            ax.plot(range(len(labels)), list(figures["success"].values()), marker="o", label=name)
        ax.set_xticks(range(len(labels)), labels)
        n = summary[size]["feasible"]["assemblies"]
        ax.set(title=f"A{size} ({n} feasible)", xlabel="budget (N = parts)", ylim=(-0.02, 1.02))
    axes[0].set_ylabel("verified order found")
    axes[0].legend(loc="lower right", fontsize=7)
    ax = axes[-1]
    infeasible = [s for s, entry in summary.items() if entry.get("infeasible")]
    if infeasible:
        names = list(summary[infeasible[0]]["infeasible"]["planners"])
        x = np.arange(len(infeasible))
        for name in names:
            values = [
                summary[s]["infeasible"]["planners"][name]["median_checks"] for s in infeasible
            ]
            ax.plot(x, [np.nan if v is None else v for v in values], marker="o", label=name)
        brute = [summary[s]["infeasible"].get("brute_force_median_checks") for s in infeasible]
        ax.plot(x, [np.nan if v is None else v for v in brute], "k--", label="brute force")
        ax.set_xticks(x, [f"A{s}" for s in infeasible])
        ax.set_yscale("log")
        ax.legend(fontsize=7)
    ax.set(title="infeasible: median checks to prove it", ylabel="step checks")
    fig.suptitle("Verified search: success against the budget of simulator step checks")
    save_figure(fig, Path(path))
