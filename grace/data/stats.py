"""Data-set statistics for `stats.json`: how rich the learning problem is, per size.

Fractions of feasible assemblies (`multi_order_fraction`, `robot_pruned_fraction`,
`nonlocal_block_fraction`) and the order counts (`orders_mean`, `orders_median`) are over the
feasible assemblies of a size; `infeasible_causes` and `infeasible_mechanisms` over the
infeasible ones, from the simulator's `info["cause"]` and `info["mechanisms"]` (a mechanism's
share counts the infeasible assemblies that lifting it alone makes feasible, so shares may add up
to more than 1; "compound" counts those no single mechanism explains; docs/world.md).
`rule_decisive_fraction` is over all assemblies: the share whose set of complete orders changes
when that rule alone is switched off (`info["decisive_rules"]`). An import without these keys
gives zeros. A quantity without any assembly to average over is `null`. `states`, `checks` and
`naive_checks` are totals over the size. `exact_copies` counts the assemblies that repeat an
earlier one of the data set exactly (part types, poses, ground truth), `renumbered_copies` those
that repeat one up to part numbering (grace/domain/canonical.py): the fold split keeps each group
of copies in one fold (docs/protocols.md).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from grace.domain.canonical import copy_groups
from grace.domain.sample import LabelledAssembly
from grace.simulation.cell_config import MECHANISMS, RULES

CAUSES = ("reach", "collision", "other")
MULTI_ORDER_MIN = 3
"""`multi_order_fraction` counts feasible assemblies with at least this many orders."""


def _fraction(count: int, total: int) -> float | None:
    return count / total if total else None


def size_stats(samples: Sequence[LabelledAssembly]) -> dict[str, Any]:
    """The `per_size` entry of `stats.json` for the assemblies of one size."""
    feasible = [s for s in samples if s.truth.feasible]
    infeasible = [s for s in samples if not s.truth.feasible]
    orders = [s.truth.n_orders() for s in feasible]
    causes = [s.info.get("cause") for s in infeasible]
    mechanisms = [set(s.info.get("mechanisms", ())) for s in infeasible]
    decisive = [set(s.info.get("decisive_rules", ())) for s in samples]
    return {
        "assemblies": len(samples),
        "infeasible_fraction": _fraction(len(infeasible), len(samples)),
        "orders_mean": float(np.mean(orders)) if orders else None,
        "orders_median": float(np.median(orders)) if orders else None,
        "multi_order_fraction": _fraction(sum(n >= MULTI_ORDER_MIN for n in orders), len(feasible)),
        "infeasible_causes": {c: _fraction(causes.count(c), len(infeasible)) for c in CAUSES},
        "infeasible_mechanisms": {
            m: _fraction(sum(m in s for s in mechanisms), len(infeasible))
            for m in (*MECHANISMS, "compound")
        },
        "rule_decisive_fraction": {
            r: _fraction(sum(r in s for s in decisive), len(samples)) for r in RULES
        },
        "robot_pruned_fraction": _fraction(
            sum(bool(s.info.get("robot_pruned")) for s in feasible), len(feasible)
        ),
        "nonlocal_block_fraction": _fraction(
            sum(bool(s.info.get("nonlocal_block")) for s in feasible), len(feasible)
        ),
        "states": int(sum(len(s.truth.states) for s in samples)),
        "naive_checks": int(sum(s.truth.naive_checks for s in samples)),
        "checks": int(sum(s.truth.checks for s in samples)),
        "exact_copies": _copies(samples, renumbered=False),
        "renumbered_copies": _copies(samples, renumbered=True),
    }


def _copies(samples: Sequence[LabelledAssembly], renumbered: bool) -> int:
    """Assemblies that are a copy of an earlier one (by copy_groups)."""
    groups = copy_groups(list(samples), renumbered)
    return int((groups != np.arange(len(groups))).sum())


def dataset_stats(
    samples: Sequence[LabelledAssembly],
    seconds_per_assembly: Mapping[int, float],
    dataset_path: str,
) -> dict[str, Any]:
    """The whole `stats.json` document; sizes are string keys, ascending."""
    sizes = sorted({s.size for s in samples})
    return {
        "per_size": {str(n): size_stats([s for s in samples if s.size == n]) for n in sizes},
        "seconds_per_assembly": {str(n): float(t) for n, t in sorted(seconds_per_assembly.items())},
        "dataset_path": str(dataset_path),
    }


SIMULATORS = ("dual_arm", "single_arm", "boxes")
"""The simulator group's choices, compared on the same generated structures."""


def simulator_comparison(
    labelled: Mapping[str, Sequence[LabelledAssembly]],
) -> dict[str, dict[str, Any]]:
    """Per size, what the robot and the second arm change, from the same structures labelled by
    `dual_arm`, `single_arm` and `boxes` (same seeds: same assemblies in the same order).

    `labels_changed_vs_*`: share of assemblies whose set of complete orders differs from
    `dual_arm`'s; `feasible_only_with_two_arms`: share feasible with two arms, not with one.
    """
    dual, single, boxes = (labelled[name] for name in SIMULATORS)
    out: dict[str, dict[str, Any]] = {}
    for size in sorted({s.size for s in dual}):
        rows = [
            (d, s, b)
            for d, s, b in zip(dual, single, boxes, strict=True)
            if d.size == size and d.assembly == s.assembly == b.assembly
        ]
        n = len(rows)
        out[str(size)] = {
            "assemblies": n,
            "infeasible_fraction": {
                name: _fraction(sum(not r[k].truth.feasible for r in rows), n)
                for k, name in enumerate(SIMULATORS)
            },
            "labels_changed_vs_boxes": _fraction(
                sum(not d.truth.same_orders(b.truth) for d, _, b in rows), n
            ),
            "labels_changed_vs_single_arm": _fraction(
                sum(not d.truth.same_orders(s.truth) for d, s, _ in rows), n
            ),
            "feasible_only_with_two_arms": _fraction(
                sum(d.truth.feasible and not s.truth.feasible for d, s, _ in rows), n
            ),
        }
    return out
