"""The side files of a run beside results.json: feasibility.json and failures.json.

Both read GRACE's per-fold summaries (grace/evaluation/evaluate.py): the feasibility schemes with
their ROC points, and the first false steps of wrongly retrieved sequences.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from grace.data.atomic import write_json_atomic
from grace.evaluation.failures import failures_report
from grace.evaluation.feasibility_schemes import feasibility_report


def write_side_files(per_fold: Sequence[dict[int, dict]], out_dir: Path) -> dict:
    """Write feasibility.json and failures.json into `out_dir`; return both reports by name."""
    reports = {
        "feasibility": feasibility_report(per_fold),
        "failures": failures_report(per_fold),
    }
    for name, report in reports.items():
        write_json_atomic(Path(out_dir) / f"{name}.json", report)
    return reports
