"""Did a fold's model learn anything? A collapsed fold must never pass silently.

A fold is collapsed when any of these holds (docs/metrics.md):

- on the test assemblies of some size its step AUC is at or below a floor policy's (`constant`,
  `never`, `random`: grace/evaluation/baselines.py) on the same states;
- its best validation step AUC during training is at or below the constant scorer's on the same
  validation states;
- its training loss never fell below the first epoch's.

The last two read the trainer's CSV log (`<fold dir>/logs/version_*/metrics.csv`); without one
they are skipped and the health record says so.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from grace.domain.sample import LabelledAssembly
from grace.evaluation.baselines import constant_scorer
from grace.evaluation.metrics import step_auc
from grace.evaluation.step_states import label_matrix, onpath_states

FLOORS = ("constant", "never", "random")


def onpath_step_auc(scorer, samples: Sequence[LabelledAssembly]) -> float:
    """The paper's step AUC of `scorer` over the on-path states of `samples` (NaN if none)."""
    scores, labels = [], []
    for sample in samples:
        states, masks = onpath_states(sample.truth)
        scores.append(np.asarray(scorer(sample.assembly, states)).ravel())
        labels.append(label_matrix(masks, sample.size).ravel())
    if not scores:
        return float("nan")
    return step_auc(np.concatenate(scores), np.concatenate(labels))


def _version(path: Path) -> int:
    return int(path.parent.name.removeprefix("version_"))


def training_history(log_dir: Path) -> list[dict[str, str]]:
    """The rows of a fit's CSV logs under `log_dir`, as one uninterrupted fit would have logged
    them: each `version_<n>` is one run of the fit, and a run that starts at epoch e (a resumed
    fit at e, a fresh one at 0) replaces the rows of epoch e on of the versions before it."""
    rows: list[dict[str, str]] = []
    for path in sorted(Path(log_dir).glob("version_*/metrics.csv"), key=_version):
        with path.open() as handle:
            new = list(csv.DictReader(handle))
        if new:
            start = int(new[0]["epoch"])
            rows = [r for r in rows if int(r["epoch"]) < start] + new
    return rows


def training_curve(log_dir: Path) -> dict | None:
    """First and lowest training loss and best validation step AUC of the fit logged under
    `log_dir` (None when there is no log)."""
    rows = training_history(log_dir)
    train = [float(r["train_loss"]) for r in rows if r.get("train_loss")]
    val_auc = [float(r["val_step_auc"]) for r in rows if r.get("val_step_auc")]
    if not train:
        return None
    return {
        "epochs": len(train),
        "train_loss_first": train[0],
        "train_loss_min": min(train),
        "val_step_auc_best": max(val_auc) if val_auc else None,
    }


def fold_health(
    metrics: Mapping[str, Mapping[int, dict]],
    val: Sequence[LabelledAssembly],
    log_dir: Path | None,
) -> dict:
    """The health record of one fold: per test size GRACE's step AUC against the best floor's,
    the training curve, and `collapsed` with its `reasons`."""
    reasons = []
    sizes = {}
    for size, entry in metrics["GRACE"].items():
        floors = [metrics[b][size]["step_auc"] for b in FLOORS if b in metrics]
        floors = [f for f in floors if not math.isnan(f)]
        if math.isnan(entry["step_auc"]) or not floors:
            continue
        sizes[str(size)] = {"step_auc": entry["step_auc"], "floor": max(floors)}
        if entry["step_auc"] <= max(floors):
            reasons.append(
                f"A{size} test step AUC {entry['step_auc']:.3f} ≤ floor {max(floors):.3f}"
            )
    curve = training_curve(log_dir) if log_dir is not None else None
    if curve is not None:
        val_floor = onpath_step_auc(constant_scorer(0), val)
        curve["val_floor"] = val_floor
        best = curve["val_step_auc_best"]
        if best is not None and not math.isnan(val_floor) and best <= val_floor:
            reasons.append(f"best validation step AUC {best:.3f} ≤ constant scorer {val_floor:.3f}")
        if not curve["train_loss_min"] < curve["train_loss_first"]:
            reasons.append("training loss never fell below its first epoch's")
    return {
        "sizes": sizes,
        "training": curve if curve is not None else "no training log found",
        "collapsed": bool(reasons),
        "reasons": reasons,
    }
