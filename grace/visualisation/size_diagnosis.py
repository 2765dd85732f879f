"""The figure of task=size_diagnosis (docs/size-generalisation.md): step scores of valid and
invalid parts per assembly size, on and off the true orders, and the network terms' scale per
size, all drawn from the numbers size_diagnosis.json holds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from grace.visualisation.plots import save_figure

KINDS = {"valid": "tab:green", "invalid": "tab:red"}
TITLES = {"onpath": "on the true orders", "offpath": "off them (after a wrong step)"}


def _box(summary: dict) -> dict | None:
    """A box from a summary's quantiles (5, 25, 50, 75, 95 %): whiskers at 5 and 95 %."""
    if not summary.get("count"):
        return None
    q = summary["quantiles"]
    return {"whislo": q[0], "q1": q[1], "med": q[2], "q3": q[3], "whishi": q[4], "fliers": []}


def size_diagnosis_figure(
    scores: dict[str, dict[str, dict[str, dict]]],
    activations: dict[str, dict[str, dict[str, float]]],
    threshold: float,
    trained: list[int],
    path: Path,
) -> None:
    """`scores[size][state set][kind]` summaries, `activations[size][term]` mean/std; sizes the
    model trained on (`trained`) are shaded."""
    sizes = sorted(scores, key=int)
    fig = Figure(figsize=(15, 4.2), layout="constrained")
    axes = fig.subplots(1, 3)
    x = np.arange(len(sizes))
    for ax, name in zip(axes[:2], TITLES, strict=True):
        for offset, (kind, colour) in zip((-0.18, 0.18), KINDS.items(), strict=True):
            boxes = [(i, _box(scores[s][name][kind])) for i, s in enumerate(sizes)]
            boxes = [(i, b) for i, b in boxes if b is not None]
            art = ax.bxp(
                [b for _, b in boxes], positions=[i + offset for i, _ in boxes], widths=0.3,
                patch_artist=True, showfliers=False,
            )  # fmt: skip
            for patch in art["boxes"]:
                patch.set(facecolor=colour, alpha=0.5)
            ax.plot([], [], color=colour, lw=6, alpha=0.5, label=f"{kind} parts")
        ax.axhline(threshold, color="k", ls="--", lw=1, label=f"λ = {threshold:g}")
        for i, s in enumerate(sizes):
            if int(s) in trained:
                ax.axvspan(i - 0.5, i + 0.5, color="0.9", zorder=0)
        ax.set(title=f"Step scores {TITLES[name]}", ylim=(-0.02, 1.02), xticks=x)
        ax.set_xticklabels([f"A{s}" for s in sizes])
    axes[0].set_ylabel("score (box 25–75 %, whiskers 5–95 %)")
    axes[0].legend(loc="center left", fontsize=8)
    ax = axes[2]
    act_sizes = sorted(activations, key=int)
    terms = sorted({t for per in activations.values() for t in per})
    for term in terms:
        values = np.array([activations[s].get(term, {}).get("mean", np.nan) for s in act_sizes])
        if not values[0] > 0:  # no scale to compare with at the smallest size
            continue
        ax.plot([int(s) for s in act_sizes], values / values[0], marker="o", label=term)
    ax.axhline(1.0, color="k", lw=0.5)
    ax.set(
        title="Activation scale per size (÷ smallest size)",
        xlabel="assembly size",
        ylabel="mean over states, relative",
        yscale="log",
    )
    ax.legend(fontsize=7, ncol=2)
    fig.suptitle("Trained on shaded sizes; held-out assemblies of every size")
    save_figure(fig, Path(path))
