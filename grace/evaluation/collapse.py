"""Did a fold's model learn anything? A collapsed fold must never pass silently.

A fold is collapsed when any of these holds (docs/metrics.md):

- on the test assemblies of some size its step AUC is at or below a floor policy's (`constant`,
  `never`, `random`: grace/evaluation/baselines.py) on the same states;
- its best validation step AUC during training is at or below the constant scorer's on the same
  validation states (the states of `datamodule.states` that training validates on, labelled as
  the logged AUC labels them);
- its training loss never fell below the first epoch's.

The last two read the trainer's CSV log (`<fold dir>/logs/version_*/metrics.csv`); without one
they are skipped and the health record says so.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from grace.domain.sample import LabelledAssembly
from grace.evaluation.baselines import constant_scorer
from grace.evaluation.metrics import step_auc
from grace.evaluation.step_states import state_scores
from grace.graphs.datamodule import StateSet
from grace.planning.sequences import Scorer

FLOORS = ("constant", "never", "random")


def state_step_auc(
    scorer: Scorer, samples: Sequence[LabelledAssembly], states: StateSet = StateSet.orders
) -> float:
    """The step AUC of `scorer` over `states` of `samples`: by default the paper's, on the
    on-path states (NaN if there is none or no positive label)."""
    return step_auc(*state_scores(scorer, samples, states))


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
    val_states: StateSet,
) -> dict:
    """The health record of one fold: per test size GRACE's step AUC against the best floor's,
    the training curve, and `collapsed` with its `reasons`. `val` and `val_states` are the
    assemblies and states the training run validated on, so the logged validation step AUC
    and its floor read the same states."""
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
        val_floor = state_step_auc(constant_scorer(0), val, StateSet(val_states))
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
