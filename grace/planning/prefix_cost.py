"""Benchmark of Algorithm 1: distinct states versus one forward pass per prefix (paper, Alg. 1).

Scoring every order of an A7 assembly needs 127 distinct states but 8,660 prefixes. The prefix
side runs the reference's forward passes (one single-state call per prefix, in DFS order); it can
be capped at `prefix_passes` calls and extrapolated linearly, which the result says.
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

from grace.domain.assembly import Assembly, full_mask
from grace.planning.sequences import Scorer, plan, score_states


def prefix_count(n_parts: int) -> int:
    """Forward passes of the per-prefix recursion at λ = 0: Σ_{k<N} N!/(N−k)!."""
    return sum(math.factorial(n_parts) // math.factorial(n_parts - k) for k in range(n_parts))


def _prefix_passes(scorer: Scorer, assembly: Assembly, limit: int) -> int:
    """Run the recursion's forward passes (one per non-complete prefix), at most `limit`."""
    n = assembly.n_parts
    full = full_mask(n)
    stack, done = [0], 0
    while stack and done < limit:
        state = stack.pop()
        scorer(assembly, np.array([state], dtype=np.int64))
        done += 1
        children = (state | 1 << p for p in range(n) if not state >> p & 1)
        stack.extend(c for c in children if c != full)
    return done


def planner_benchmark(
    scorer: Scorer, assembly: Assembly, repeats: int = 5, prefix_passes: int | None = None
) -> dict:
    """Time scoring every order of `assembly` via distinct states and via per-prefix passes.

    `distinct_ms` is the median of `repeats` runs, `distinct_ms_first` the first one (it includes
    whatever per-assembly work a caching scorer does once, e.g. the surface embedding).
    """
    timings, sequences, passes = [], 0, 0
    for _ in range(repeats):
        start = time.perf_counter()
        scored = score_states(scorer, assembly, threshold=0.0)
        sequences = len(plan(scored, 0.0))
        timings.append(time.perf_counter() - start)
        passes = scored.passes
    total = prefix_count(assembly.n_parts)
    limit = total if prefix_passes is None else min(prefix_passes, total)
    start = time.perf_counter()
    measured = _prefix_passes(scorer, assembly, limit)
    prefix_s = (time.perf_counter() - start) * total / measured
    result = {
        "n_parts": assembly.n_parts,
        "sequences": sequences,
        "distinct_passes": passes,
        "distinct_ms": 1000 * statistics.median(timings),
        "distinct_ms_first": 1000 * timings[0],
        "prefix_passes": total,
        "prefix_passes_measured": measured,
        "prefix_ms": 1000 * prefix_s,
    }
    result["speedup"] = result["prefix_ms"] / result["distinct_ms"]
    print(
        f"A{assembly.n_parts}: all {sequences} orders scored via {passes} distinct states in "
        f"{result['distinct_ms']:.1f} ms (first call {result['distinct_ms_first']:.1f} ms); "
        f"per-prefix recursion {total} forward passes {result['prefix_ms'] / 1000:.2f} s"
        + ("" if measured == total else f" (extrapolated from {measured})")
        + f"; speed-up {result['speedup']:.0f}×"
    )
    return result
