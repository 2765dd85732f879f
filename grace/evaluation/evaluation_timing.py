"""Timing of one policy's whole evaluation (task=bench); a figure, not a test."""

from __future__ import annotations

import time

from grace.domain.sample import LabelledAssembly
from grace.evaluation.evaluate import evaluate_by_size
from grace.planning.sequences import Scorer


def evaluate_ms_per_assembly(scorer: Scorer, samples: list[LabelledAssembly]) -> float:
    """Milliseconds per assembly of one policy's whole evaluation on `samples`."""
    start = time.perf_counter()
    evaluate_by_size(scorer, samples)
    return 1000.0 * (time.perf_counter() - start) / len(samples)
