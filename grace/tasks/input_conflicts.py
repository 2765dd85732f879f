"""`python -m grace task=input_conflicts`: how far the Assembly Graph's input decides the step
labels (docs/information-ceiling.md). No training.

For the data set of this command and the folds of its protocol (docs/protocols.md), it counts per
test size the steps (state and candidate part) of the test assemblies whose network input
(grace/evaluation/input_conflicts.py) equals a training step's, those whose label (valid next
step or not) differs from that training step's, and the Bayes ceiling on them; and, over all
assemblies of each size, the steps of equal input and different labels. The steps are those the
network trains on (`task.states`, by default `datamodule.states`), the encoding the model's
(`model.graph`, so a variant of the graph is measured as it would be trained). With
`task.moves` ([dx, dy] shifts in mm), the first `task.moved_per_size` assemblies of each size are
also moved by each shift and labelled by this run's simulator (the one that labelled a generated
data set): steps of equal input whose label the move changes. Writes input_conflicts.json and
input_conflicts.md into the run folder.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig

from grace.cli.folds import protocol_folds
from grace.cli.runner import TaskSettings
from grace.data.atomic import write_text_atomic
from grace.domain.sample import LabelledAssembly
from grace.evaluation.input_conflicts import (
    InputKeys,
    Steps,
    add_counts,
    against_training,
    move_conflicts,
    within,
)
from grace.evaluation.tables import input_conflicts_table
from grace.roles import PLANNING

log = logging.getLogger(__name__)


@dataclass
class InputConflictsSettings(TaskSettings):
    """Schema of `task=input_conflicts` (values in grace/conf/task/input_conflicts.yaml)."""

    reads: ClassVar[tuple[str, ...] | None] = ("model", "datamodule")
    # orders | reachable: the steps counted (the network's training states)
    states: str = field(default=MISSING, metadata=PLANNING)
    # [dx, dy] mm shifts; [] = none
    moves: list[list[float]] = field(default_factory=list, metadata=PLANNING)
    # assemblies per size moved by each shift
    moved_per_size: int = field(default=20, metadata=PLANNING)


def _of_size(steps: list[Steps], data: list[LabelledAssembly], size: int) -> list[Steps]:
    return [st for st, sample in zip(steps, data, strict=True) if sample.size == size]


def _moves(
    cfg: DictConfig, keys: InputKeys, data: list[LabelledAssembly], sizes: list[int]
) -> dict[str, dict[str, float]]:
    """Per size, the counts of grace.evaluation.input_conflicts.move_conflicts over the first
    `task.moved_per_size` assemblies, and the Bayes ceiling on the original and moved steps."""
    simulator = instantiate(cfg.simulator)
    moves = [[float(v) for v in move] for move in cfg.task.moves]
    report = {}
    for size in sizes:
        chosen = [x for x in data if x.size == size][: cfg.task.moved_per_size]
        counts = [move_conflicts(keys, x, simulator.label, moves, cfg.task.states) for x in chosen]
        total = {k: sum(c[k] for c in counts) for k in counts[0]} if counts else {}
        steps = total.get("steps", 0)
        # original and moved steps pooled: at best one of each changed pair is right
        total["ceiling"] = 1.0 - total.get("label_changes", 0) / (2 * steps) if steps else 1.0
        report[str(size)] = total
        log.info("A%d moved: %s", size, total)
    return report


def run(cfg: DictConfig) -> None:
    """Count the steps of equal network input and different labels, per fold and size."""
    data = instantiate(cfg.dataset).load()
    _, test_sizes, folds = protocol_folds(cfg, data)
    keys = InputKeys(instantiate(cfg.model.graph))
    steps = [keys.training_steps(sample, cfg.task.states) for sample in data]
    sizes = sorted({sample.size for sample in data})
    per_fold: dict[int, list[dict[str, float]]] = {s: [] for s in test_sizes}
    for fold in folds:
        train = Steps.concat([steps[i] for i in fold.train])
        for size in test_sizes:
            test = Steps.concat([steps[i] for i in fold.test if data[i].size == size])
            per_fold[size].append(against_training(train, test))
    report = {
        "protocol": cfg.protocol.name,
        "folds": len(folds),
        "states": cfg.task.states,
        "distinct_inputs": {
            str(s): len({keys.input_id(x) for x in data if x.size == s}) for s in sizes
        },
        "assemblies": {str(s): sum(1 for x in data if x.size == s) for s in sizes},
        "test": {str(s): add_counts(per_fold[s]) for s in test_sizes},
        "within": {
            str(s): add_counts([within(Steps.concat(_of_size(steps, data, s)))]) for s in sizes
        },
    }
    if cfg.task.moves:
        report["moves"] = _moves(cfg, keys, data, sizes)
    out = Path(cfg.paths.output_dir)
    write_text_atomic(out / "input_conflicts.json", json.dumps(report, indent=2) + "\n")
    write_text_atomic(out / "input_conflicts.md", input_conflicts_table(report) + "\n")
    for size, counts in report["test"].items():
        log.info(
            "A%s: %d test steps, %d with a training twin, %d of other label, ceiling %.4f",
            size, counts["steps"], counts["seen_in_training"], counts["label_conflicts"],
            counts["ceiling"],
        )  # fmt: skip
    log.info("input conflicts in %s", out)
