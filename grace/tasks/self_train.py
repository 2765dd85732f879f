"""`python -m grace task=self_train protocol=upward`: expert iteration ("self-training") on larger
assemblies labelled by the verified search (docs/size-generalisation.md, "Self-training").

The policy of the paper (Sec. IV) learns by imitation of brute-forced orders, which larger
assemblies cannot afford. Here each round r = 1..R draws `task.sizes` new unlabelled assemblies
(seed `task.draw_seed`, no ground truth: grace/data/unlabelled.py; copies of a test
assembly dropped by layout), plans each with the verified search of `planner=` and the previous
round's model, and labels it from the plan's verified orders only (grace/planning/
self_labels.py: a partial label, masked to what the search knows unless
`task.mask_unknown=false`); then a fresh model (same seed, `task.fit`, the training entry
of every task) trains on the protocol fold's training assemblies plus every self-labelled one so
far, and is scored on the fold's test assemblies (`evaluate_by_size`, docs/metrics.md). Its
first choice and the test's Algorithm 1 plan under the run's `threshold=` rule, as
`task=experiment` plans its folds; the search orders its steps by the model's own scores, as
`task=plan` does. Round 0
is the model trained on the original set only (R = 0). `task.labels=brute_force` labels the
same drawn assemblies by the simulator's brute force instead: the upper bound of the same data.
The test assemblies' ground truth is read only to score. Each round's model is also judged on the
next round's draws by its first choice, checked by the simulator (the last one on one more draw),
and the round judged best is named (`chosen_round`): R chosen without any ground truth. After
every round self_train.json and self_train.md are rewritten (atomically) in the run folder;
with `task.patience` the rounds stop once that many judged rounds were none better. Returns
the chosen round's mean strict P@1 over the test sizes (the last round's when none was
chosen, R = 0).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig, OmegaConf

from grace.cli.folds import protocol_folds
from grace.cli.runner import TaskSettings, task_overrides
from grace.data.atomic import write_json_atomic, write_text_atomic
from grace.data.unlabelled import UnlabelledDraws
from grace.domain.assembly import Assembly
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.evaluation.evaluate import evaluate_by_size
from grace.evaluation.expert_iteration import (
    brute_force_labeller,
    expert_iteration,
    search_labeller,
)
from grace.evaluation.self_train import (
    Labels,
    RoundFigures,
    chosen_round,
    model_overrides,
    self_train_markdown,
    size_figures,
)
from grace.model.scoring import make_scorer
from grace.planning.search import VerifiedSearch
from grace.planning.sequences import Scorer
from grace.roles import PLANNING, WEIGHTS


@dataclass
class SelfTrainSettings(TaskSettings):
    """Schema of `task=self_train` (values in grace/conf/task/self_train.yaml)."""

    # (cfg, train, val, out_dir, callbacks) -> trained module, a partial
    fit: Any = field(default=MISSING, metadata=WEIGHTS)
    # R; 0: the original training set only
    rounds: int = field(default=MISSING, metadata=WEIGHTS)
    # size → unlabelled assemblies drawn per round
    sizes: Any = field(default=MISSING, metadata=WEIGHTS)
    # what `sizes` interpolates unless overridden whole
    default_sizes: Any = field(default=None, metadata=WEIGHTS)
    # their generator seed (not the data set's `dataset.seed`)
    draw_seed: int = field(default=MISSING, metadata=WEIGHTS)
    labels: Labels = field(default=Labels.verified, metadata=WEIGHTS)
    # verified labels: no loss on the parts whose label the search does not know
    mask_unknown: bool = field(default=True, metadata=WEIGHTS)
    # verified labels: checks per sub-search deciding a step the search left unknown; None: none
    probe_checks: int | None = field(default=None, metadata=WEIGHTS)
    # probed labels: also decide the states on the policy's own first choice (at `threshold`)
    probe_own_sequence: bool = field(default=False, metadata=WEIGHTS)
    # stop once this many judged rounds in a row were none better than an earlier one; None: R
    patience: int | None = field(default=None, metadata=WEIGHTS)
    # the protocol's fold: its training, validation and test assemblies
    fold: int = field(default=0, metadata=WEIGHTS)
    # λ of P@1 and of "no complete sequence" (docs/metrics.md)
    threshold: float = field(default=0.5, metadata=PLANNING)


def run(cfg: DictConfig) -> float:
    """Self-train on the protocol's fold `task.fold`; return the chosen round's mean strict P@1."""
    out_dir = Path(cfg.paths.output_dir)
    task = cfg.task
    data = instantiate(cfg.dataset).load()
    _, _, folds = protocol_folds(cfg, data)
    if not 0 <= int(task.fold) < len(folds):
        raise UserError(f"task.fold={task.fold}; fix: a fold from 0 to {len(folds) - 1}")
    fold = folds[int(task.fold)]
    train, val, test = ([data[i] for i in idx] for idx in (fold.train, fold.val, fold.test))
    sizes = {int(n): int(c) for n, c in (task.sizes or {}).items()}
    simulator = instantiate(cfg.simulator)
    draws = UnlabelledDraws(simulator, int(task.draw_seed))

    def draw(r: int) -> list[Assembly]:
        return [d.assembly for d in draws.batch(r, sizes, test)]

    rule = instantiate(cfg.threshold)
    if task.labels == Labels.brute_force:
        label = brute_force_labeller(simulator, float(task.threshold), rule)
    else:
        search = instantiate(cfg.planner)
        if not isinstance(search, VerifiedSearch):
            raise UserError(
                f"planner={OmegaConf.select(cfg, 'planner._target_')} is not a verified search; "
                "fix: task=self_train labels by planner=verified (drop planner=topk)"
            )
        probe = None if task.probe_checks is None else int(task.probe_checks)
        label = search_labeller(
            search, simulator, bool(task.mask_unknown), probe, float(task.threshold),
            bool(task.probe_own_sequence), rule,
        )  # fmt: skip
    fit_module = instantiate(task.fit)

    def fit(samples: list[LabelledAssembly], r: int) -> Scorer:
        return make_scorer(fit_module(cfg, samples, val, out_dir / f"round_{r}"))

    def score(scorer: Scorer) -> dict:  # the one place the test assemblies' truth is read
        metrics = evaluate_by_size(rule(scorer), test, [1], float(task.threshold), int(cfg.seed))
        return size_figures(metrics)

    settings = {
        "labels": str(task.labels), "mask_unknown": bool(task.mask_unknown),
        "probe_checks": task.probe_checks, "probe_own_sequence": bool(task.probe_own_sequence),
        "rounds": int(task.rounds), "patience": task.patience, "sizes": sizes,
        "draw_seed": int(task.draw_seed), "fold": int(task.fold), "seed": int(cfg.seed),
        "train": len(train), "val": len(val), "test": len(test),
        "planner": OmegaConf.to_container(cfg.planner, resolve=True),
        "threshold": OmegaConf.to_container(cfg.threshold, resolve=True),
        "model": model_overrides(task_overrides()),
    }  # fmt: skip

    def report(rounds: list[RoundFigures]) -> None:
        chosen = chosen_round([r.first_choice for r in rounds])
        body = {
            "settings": settings,
            "rounds": [r.to_json() for r in rounds],
            "chosen_round": chosen,
        }
        write_json_atomic(out_dir / "self_train.json", body)
        shown = {k: v for k, v in settings.items() if k not in ("planner", "threshold")}
        shown["threshold"] = type(rule).__name__
        write_text_atomic(out_dir / "self_train.md", self_train_markdown(shown, rounds))

    patience = None if task.patience is None else int(task.patience)
    done = expert_iteration(int(task.rounds), train, draw, fit, label, score, report, patience)
    chosen = chosen_round([r.first_choice for r in done])
    kept = [f["p_at_1_strict"] for f in done[-1 if chosen is None else chosen].test.values()]
    print(self_train_markdown({"labels": str(task.labels)}, done))
    print(f"self_train.json and self_train.md in {out_dir}")
    return float(np.mean(kept)) if kept else float("nan")
