"""Figures of the run's side files: feasibility ROC curves and the failure histogram.

`feasibility_roc.png`: per test size, the fold-mean ROC curve of every feasibility scheme (the
paper's Fig. 5), the diagonal as the floor. `failures.png`: per test size, how many wrongly
retrieved sequences first go wrong at each step, and the score distribution of those steps per
step index (the paper's Fig. 6: are early mistakes confident, late ones not?).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from grace.visualisation.plots import save_figure


def feasibility_roc(report: dict, path: Path) -> None:
    """ROC curves of every scheme in a feasibility report, one panel per test size."""
    per_size = report["per_size"]
    sizes = sorted(per_size, key=int)
    fig = Figure(figsize=(3.4 * max(len(sizes), 1), 3.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, max(len(sizes), 1)))
    for ax, size in zip(axes, sizes, strict=False):
        ax.plot([0, 1], [0, 1], color="0.6", linestyle=":", label="floor (chance)")
        for scheme, entry in per_size[size].items():
            auc = entry["roc_auc"]["mean"]
            ax.plot(entry["roc"]["fpr"], entry["roc"]["tpr"], label=f"{scheme} ({auc:.2f})")
        ax.axvline(report["max_fpr"], color="0.8", linewidth=0.8)
        ax.set(
            title=f"A{size}", xlabel="FPR (infeasible called feasible)", xlim=(0, 1), ylim=(0, 1.02)
        )
        ax.legend(loc="lower right", fontsize=6)
    axes[0].set_ylabel("TPR (feasible called feasible)")
    fig.suptitle("Feasibility ROC per scheme (fold mean; ROC AUC in brackets)")
    save_figure(fig, Path(path))


def failure_histograms(report: dict, path: Path) -> None:
    """Top: wrongly retrieved sequences by the step index of their first false step, feasible and
    infeasible assemblies stacked. Bottom: on feasible assemblies, the score distribution of those
    steps per step index (share of the step's sequences per score bin)."""
    per_size = report["per_size"]
    sizes = sorted(per_size, key=int)
    fig = Figure(figsize=(3.4 * max(len(sizes), 1), 5.6), layout="constrained")
    axes = fig.subplots(2, max(len(sizes), 1), squeeze=False)
    for column, size in enumerate(sizes):
        feasible, infeasible = per_size[size]["feasible"], per_size[size]["infeasible"]
        top, bottom = axes[0, column], axes[1, column]
        steps = sorted({*feasible["by_step"], *infeasible["by_step"]}, key=int)
        below = np.zeros(len(steps))
        for kind, entry, colour in (
            ("feasible", feasible, "tab:red"),
            ("infeasible", infeasible, "0.6"),
        ):
            counts = np.array([entry["by_step"].get(s, {}).get("sequences", 0) for s in steps])
            top.bar([int(s) for s in steps], counts, bottom=below, color=colour, label=kind)
            below = below + counts
        total = feasible["wrong_sequences"] + infeasible["wrong_sequences"]
        top.set(title=f"A{size}: {total} wrong sequences", xlabel="first false step")
        edges = np.asarray(feasible["bins"])
        centres = (edges[:-1] + edges[1:]) / 2
        for step, entry in feasible["by_step"].items():
            hist = np.asarray(entry["sequences_by_score"], dtype=float)
            if hist.sum():
                bottom.plot(
                    centres, hist / hist.sum(), marker="o", markersize=3, label=f"step {step}"
                )
        bottom.set(xlabel="score of the false step (feasible assemblies)")
        if len(edges):
            bottom.set_xlim(edges[0], edges[-1])
        if feasible["by_step"]:
            bottom.legend(fontsize=6)
        if not steps:
            top.text(0.5, 0.5, "no wrong sequence", ha="center", transform=top.transAxes)
    axes[0, 0].set_ylabel("wrong sequences")
    axes[0, 0].legend(fontsize=6)
    axes[1, 0].set_ylabel("share of the step's sequences")
    fig.suptitle("First false steps of wrongly retrieved sequences (all folds)")
    save_figure(fig, Path(path))


def draw_side_files(reports: dict, out_dir: Path) -> None:
    """feasibility_roc.png and failures.png from the reports of grace.evaluation.side_files."""
    feasibility_roc(reports["feasibility"], Path(out_dir) / "feasibility_roc.png")
    failure_histograms(reports["failures"], Path(out_dir) / "failures.png")
