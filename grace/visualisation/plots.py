"""PNG figures of an experiment run: sequence PR curves and P@k bars (strict and the paper's).

Drawn on bare matplotlib Figures (Agg canvas, no pyplot state) and written atomically.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from grace.data.atomic import write_bytes_atomic
from grace.evaluation.results import SizeSummary
from grace.evaluation.tables import p_at_k, value


def save_figure(fig: Figure, path: Path) -> None:
    """Write `fig` as a PNG to `path` atomically."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=120, bbox_inches="tight")
    write_bytes_atomic(path, buffer.getvalue())


def pr_curves(curves: dict[str, dict[str, dict]], path: Path) -> None:
    """IR precision–recall curves per test size, one line per policy.

    `curves[policy][size]` = {"recall": [...], "precision": [...]} (the fold-mean curve).
    """
    sizes = sorted({s for per_size in curves.values() for s in per_size}, key=int)
    fig = Figure(figsize=(3.2 * max(len(sizes), 1), 3.4), layout="constrained")
    axes = fig.subplots(1, max(len(sizes), 1))
    for ax, size in zip(np.atleast_1d(axes), sizes, strict=False):
        for policy, per_size in curves.items():
            if size in per_size:
                ax.plot(per_size[size]["recall"], per_size[size]["precision"], label=policy)
        ax.set(title=f"A{size}", xlabel="IR recall", xlim=(0, 1.02), ylim=(0, 1.02))
    np.atleast_1d(axes)[0].set_ylabel("IR precision")
    np.atleast_1d(axes)[0].legend(loc="lower left")
    fig.suptitle("Complete-sequence precision–recall (λ sweep)")
    save_figure(fig, Path(path))


def p_at_k_bars(policies: dict[str, dict[str, SizeSummary]], path: Path) -> None:
    """Grouped bars of P@k (mean ± std over folds) per test size and policy.

    The filled bar is the strict P@k (an empty retrieval counts 0); the outline above it reaches
    the paper's P@k (an empty retrieval counts 1), so the gap is what empty retrievals add. Bars
    with empty retrievals say how many of the counted assemblies those were.
    """
    sizes = sorted({s for per_size in policies.values() for s in per_size}, key=int)
    ks = (1, 2, 3)
    fig = Figure(figsize=(3.6 * len(ks), 3.4), layout="constrained")
    axes = fig.subplots(1, len(ks), sharey=True)
    width = 0.8 / max(len(policies), 1)
    x = np.arange(len(sizes))
    for ax, k in zip(axes, ks, strict=True):
        for i, (policy, per_size) in enumerate(policies.items()):
            paper = [value(per_size.get(s), p_at_k(k, strict=False)) for s in sizes]
            strict = [value(per_size.get(s), p_at_k(k, strict=True)) for s in sizes]
            means = [st.mean if st else np.nan for st in strict]
            stds = [st.std if st else 0.0 for st in strict]
            colour = f"C{i}"
            bars = ax.bar(
                x + i * width, means, width, yerr=stds, label=policy, capsize=2, color=colour
            )
            outline = [st.mean if st else np.nan for st in paper]
            ax.bar(x + i * width, outline, width, fill=False, edgecolor=colour, linestyle="--")
            for bar, st in zip(bars, paper, strict=True):
                if st and st.empty:
                    ax.annotate(
                        f"{st.empty}/{st.assemblies}\nempty",
                        (bar.get_x() + bar.get_width() / 2, 0.02),
                        ha="center",
                        fontsize=6,
                    )
        ax.set(title=f"P@{k} (λ = 0.5)", xticks=x + width * (len(policies) - 1) / 2, ylim=(0, 1.05))
        ax.set_xticklabels([f"A{s}" for s in sizes])
    axes[0].set_ylabel("strict P@k (dashed: paper's, empty = 1)")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside right upper")
    save_figure(fig, Path(path))
