"""`python -m grace task=size_diagnosis ckpt=<experiment run folder> task.fold=0 ...`: how a kept
model's step scores and activations change with the assembly size (docs/size-generalisation.md).

For the model of one fold of an experiment run, and the data set of this command (which must be
the run's own, optionally with more sizes above its largest, e.g. scale=upward beside the
default scale), it takes the fold's held-out assemblies of every size (no model of that fold
trained or early-stopped on them, grace/evaluation/size_scores.py), up to `task.per_size` per
size, and writes per size:
- the distribution of step scores of valid and invalid parts, on and off the true orders;
- the scale of the network's size-dependent terms, measured with forward hooks
  (grace/evaluation/activation_scale.py);
into size_diagnosis.json, size_diagnosis.png and (as a table) size_diagnosis.md in the run
folder.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path

from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig, OmegaConf

from grace.cli.checks import protocol_split
from grace.cli.runner import TaskSettings
from grace.data.atomic import write_text_atomic
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.evaluation.activation_scale import activation_scale
from grace.evaluation.size_scores import held_out, step_scores, summarise
from grace.evaluation.tables import size_diagnosis_table
from grace.model.checkpoints import load_model
from grace.model.grace_pyg import pyg_layers
from grace.model.kept import find_checkpoint
from grace.model.scoring import make_scorer
from grace.roles import PLANNING
from grace.visualisation.size_diagnosis import size_diagnosis_figure

log = logging.getLogger(__name__)


@dataclass
class SizeDiagnosisSettings(TaskSettings):
    """Schema of `task=size_diagnosis` (values in grace/conf/task/size_diagnosis.yaml)."""

    # an experiment run folder (or a fold's .ckpt inside one)
    ckpt: str | None = field(default=MISSING, metadata=PLANNING)
    # which fold's model, and whose held-out assemblies
    fold: int = field(default=0, metadata=PLANNING)
    # sizes to diagnose (None: every size of the data set)
    sizes: list[int] | None = field(default=None, metadata=PLANNING)
    # held-out assemblies per size, at most
    per_size: int = field(default=30, metadata=PLANNING)
    # states per assembly whose activations are measured
    states_per_assembly: int = field(default=32, metadata=PLANNING)
    # λ drawn in the figure, and the share of scores at or above it
    threshold: float = field(default=0.5, metadata=PLANNING)


def _check_same_data(kept: DictConfig, cfg: DictConfig, counts: dict[int, int]) -> None:
    """Raise a UserError unless the fold's held-out assemblies can be recovered from this data
    set: the run's data seed, its sizes with their counts, further sizes only above them."""
    trained = {int(k): int(v) for k, v in (OmegaConf.select(kept, "dataset.sizes") or {}).items()}
    first = {s: counts.get(s) for s in trained}
    below = [s for s in counts if s not in trained and s < max(trained, default=0)]
    same_seed = OmegaConf.select(kept, "dataset.seed") == OmegaConf.select(cfg, "dataset.seed")
    if not trained or first != trained or below or not same_seed:
        raise UserError(
            f"task=size_diagnosis: dataset (sizes {counts}, seed {cfg.dataset.seed}) is not the "
            f"data set of the run ({trained or 'unknown'}, seed {kept.dataset.seed}); fix: use "
            "the run's scale/dataset.sizes and seed, adding sizes only above its largest"
        )


def run(cfg: DictConfig) -> None:
    """Diagnose the model of `task.fold` of the run `task.ckpt` on its held-out assemblies."""
    settings = cfg.task
    # PyG's layers: the activation probe hooks the reference path's modules
    module, kept = load_model(find_checkpoint(settings.ckpt, settings.fold), pyg_layers())
    if OmegaConf.select(kept, "task.name") != "experiment":
        raise UserError(
            f"ckpt={settings.ckpt}: not a fold of an experiment run; fix: pass the folder of a "
            "python -m grace run (its folds say which assemblies no model saw)"
        )
    data = instantiate(cfg.dataset).load()
    counts = {s: sum(1 for d in data if d.size == s) for s in sorted({d.size for d in data})}
    _check_same_data(kept, cfg, counts)
    unseen = [
        data[i] for i in held_out(data, kept.protocol.folds, kept.protocol.seed, settings.fold)
    ]
    sizes = sorted(counts) if settings.sizes is None else [int(s) for s in settings.sizes]
    scorer = make_scorer(module)
    scores, activations = {}, {}
    for size in sizes:
        chosen: list[LabelledAssembly] = [d for d in unseen if d.size == size][: settings.per_size]
        if not chosen:
            raise UserError(f"task.sizes: no held-out assembly of size {size} in the data set")
        by_set = step_scores(scorer, chosen)
        scores[str(size)] = {
            name: {kind: summarise(v, settings.threshold) for kind, v in kinds.items()}
            for name, kinds in by_set.items()
        }
        scores[str(size)]["assemblies"] = len(chosen)
        activations[str(size)] = activation_scale(module, chosen, settings.states_per_assembly)
        log.info("A%d: %d held-out assemblies diagnosed", size, len(chosen))
    trained, _ = protocol_split(kept.protocol, [int(s) for s in kept.dataset.sizes])
    out = Path(cfg.paths.output_dir)
    report = {
        "ckpt": str(settings.ckpt),
        "fold": settings.fold,
        "model": kept.model.name,
        "train_sizes": trained,
        "threshold": settings.threshold,
        "scores": scores,
        "activations": activations,
    }
    write_text_atomic(out / "size_diagnosis.json", json.dumps(report, indent=2) + "\n")
    write_text_atomic(out / "size_diagnosis.md", size_diagnosis_table(report) + "\n")
    size_diagnosis_figure(
        scores, activations, settings.threshold, trained, out / "size_diagnosis.png"
    )
    log.info("size diagnosis in %s", out)
