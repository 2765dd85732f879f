"""`python -m grace task=report 'task.roots=[multirun/table2]'`: the results book of sweep runs.

Reads every results.json under the given folders and writes report.md into the run folder: per
protocol a markdown table (strict figures first, floors beside; Table 3's layout for one-to-many;
a row per variant where several ran; seeds pooled as mean ± std), each preceded by the command
lines that made its runs (from their `.hydra` records) and the one that wrote the book
(grace/evaluation/book.py). docs/results.md is pasted from such books.
"""

from __future__ import annotations

import logging
import shlex
from dataclasses import dataclass, field
from pathlib import Path

from omegaconf import MISSING, DictConfig

from grace.cli.key_roles import experiment_run_keys
from grace.cli.runner import TaskSettings, task_overrides
from grace.data.atomic import write_text_atomic
from grace.evaluation.book import ENTRY, results_book
from grace.evaluation.gather import find_results
from grace.roles import RUN

log = logging.getLogger(__name__)


@dataclass
class ReportSettings(TaskSettings):
    """Schema of `task=report` (values in grace/conf/task/report.yaml)."""

    roots: list[str] = field(default=MISSING, metadata=RUN)


def run(cfg: DictConfig) -> None:
    """Write report.md, the results book of the runs under `cfg.task.roots`."""
    paths = find_results(cfg.task.roots)
    command = shlex.join([*ENTRY, *task_overrides()])
    book = results_book(paths, command, experiment_run_keys())
    out_dir = Path(cfg.paths.output_dir)
    write_text_atomic(out_dir / "report.md", book)
    print(book)
    log.info("results book of %d runs in %s", len(paths), out_dir / "report.md")
