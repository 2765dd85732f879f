"""`python -m grace task=gather task.roots=[multirun/table2]`: combine runs into the paper's tables.

Reads every results.json under the given folders and writes gather.md and gather.json into the run
folder (grace/evaluation/gather.py: Table 2, Table 3, variants as blocks of rows, seeds pooled).
Self-training runs (their self_train.json) pool into self_train_gather.md instead
(grace/evaluation/self_train.py, `pooled_markdown`: a row per label source and round).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

from omegaconf import MISSING, DictConfig

from grace.cli.key_roles import experiment_run_keys
from grace.cli.runner import TaskSettings
from grace.data.atomic import write_text_atomic
from grace.evaluation.gather import collect, find_results, gather_markdown
from grace.evaluation.results import to_json
from grace.evaluation.self_train import SELF_TRAIN_FILE, pooled_markdown, read_self_train
from grace.roles import RUN

log = logging.getLogger(__name__)


@dataclass
class GatherSettings(TaskSettings):
    """Schema of `task=gather` (values in grace/conf/task/gather.yaml)."""

    roots: list[str] = field(default=MISSING, metadata=RUN)


def run(cfg: DictConfig) -> None:
    """Gather the runs under `cfg.task.roots` into gather.md and gather.json, or self-training
    runs into self_train_gather.md."""
    out_dir = Path(cfg.paths.output_dir)
    self_trained = find_results(cfg.task.roots, SELF_TRAIN_FILE, required=False)
    if self_trained:
        markdown = pooled_markdown([read_self_train(p) for p in self_trained])
        write_text_atomic(out_dir / "self_train_gather.md", markdown)
        print(markdown)
        log.info("gathered %d self-training runs into %s", len(self_trained), out_dir)
        return
    paths = find_results(cfg.task.roots)
    tables = collect(paths, experiment_run_keys())
    write_text_atomic(out_dir / "gather.json", to_json(tables))
    markdown = gather_markdown(tables)
    write_text_atomic(out_dir / "gather.md", markdown)
    print(markdown)
    log.info("gathered %d runs into %s", len(paths), out_dir)
