"""Data-set statistics for `stats.json` (issue 2): how rich the learning problem is, per size.

Fractions of feasible assemblies (`multi_order_fraction`, `robot_pruned_fraction`,
`nonlocal_block_fraction`) and the order counts (`orders_mean`, `orders_median`) are over the
feasible assemblies of a size; `infeasible_causes` over the infeasible ones, from the simulator's
`info["cause"]` (an import without causes gives zeros). A quantity without any assembly to
average over is `null`. `states`, `checks` and `naive_checks` are totals over the size.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from grace.domain.sample import LabelledAssembly

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
    return {
        "assemblies": len(samples),
        "infeasible_fraction": _fraction(len(infeasible), len(samples)),
        "orders_mean": float(np.mean(orders)) if orders else None,
        "orders_median": float(np.median(orders)) if orders else None,
        "multi_order_fraction": _fraction(sum(n >= MULTI_ORDER_MIN for n in orders), len(feasible)),
        "infeasible_causes": {c: _fraction(causes.count(c), len(infeasible)) for c in CAUSES},
        "robot_pruned_fraction": _fraction(
            sum(bool(s.info.get("robot_pruned")) for s in feasible), len(feasible)
        ),
        "nonlocal_block_fraction": _fraction(
            sum(bool(s.info.get("nonlocal_block")) for s in feasible), len(feasible)
        ),
        "states": int(sum(len(s.truth.states) for s in samples)),
        "naive_checks": int(sum(s.truth.naive_checks for s in samples)),
        "checks": int(sum(s.truth.checks for s in samples)),
    }


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
