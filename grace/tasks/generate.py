"""`python -m grace task=generate`: make (or finish) the data set, write its statistics (stats.json,
the same as markdown tables in stats.md) and a top view.

With `dataset.num_shards>1` a run generates only its share; stats and the picture are written by
whichever run finds the data set complete. `task.export_raw=/folder` also exports every assembly
in the raw format (docs/raw-format.md) as `<folder>/A<size>/<name>/`.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig

from grace.cli.runner import TaskSettings
from grace.data.atomic import write_bytes_atomic, write_json_atomic, write_text_atomic
from grace.data.raw_format import export_raw
from grace.data.stats import dataset_stats
from grace.data.store import GeneratedSource, seconds_per_assembly
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.evaluation.tables import dataset_tables
from grace.roles import RUN
from grace.visualisation.topview import topview_png

log = logging.getLogger(__name__)


@dataclass
class GenerateSettings(TaskSettings):
    """Schema of `task=generate` (values in grace/conf/task/generate.yaml)."""

    topview: int = field(default=MISSING, metadata=RUN)
    export_raw: str | None = field(default=MISSING, metadata=RUN)


STATS_FILE = "stats.json"
STATS_TABLES = "stats.md"
TOPVIEW_FILE = "topview.png"


def pick_examples(samples: Sequence[LabelledAssembly], count: int) -> list[LabelledAssembly]:
    """Up to `count` to draw: per size, largest first, its first feasible and infeasible one."""
    picked: list[LabelledAssembly] = []
    for size in sorted({s.size for s in samples}, reverse=True):
        for feasible in (True, False):
            match = next(
                (s for s in samples if s.size == size and s.truth.feasible == feasible), None
            )
            if match is not None and len(picked) < count:
                picked.append(match)
    return picked


def run(cfg: DictConfig) -> None:
    """Generate this run's share; once the data set is complete, write statistics and top view."""
    source = instantiate(cfg.dataset)
    if not isinstance(source, GeneratedSource):
        raise UserError(
            f"task=generate makes a generated data set, but dataset is a {type(source).__name__}; "
            "fix: drop the dataset= override (dataset=generated)"
        )
    generation = source.generate()
    if not generation.complete:
        log.info(
            "%d chunks still missing (other shards); stats are written once all exist",
            generation.missing,
        )
        return None
    samples = source.read(generation)
    out = Path(cfg.paths.output_dir)
    seconds = seconds_per_assembly(generation.path, generation.chunks)
    stats = dataset_stats(samples, seconds, str(generation.path))
    write_json_atomic(out / STATS_FILE, stats)
    write_text_atomic(out / STATS_TABLES, dataset_tables(stats) + "\n")
    examples = pick_examples(samples, int(cfg.task.topview))
    if examples:
        write_bytes_atomic(out / TOPVIEW_FILE, topview_png(examples))
    if cfg.task.export_raw:
        for sample in samples:
            export_raw(sample, Path(cfg.task.export_raw) / f"A{sample.size}" / sample.assembly.name)
    log.info("%d assemblies in %s; stats in %s", len(samples), generation.path, out / STATS_FILE)
    return None
