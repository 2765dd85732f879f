"""Train on the states the planner visits: one DAgger-style round.

A model trained on the ground-truth orders only has never seen the states its own planner enters
after a wrong step. `train_dagger` trains a first model as the configured fit does, runs
Algorithm 1 (grace/planning/sequences.py) with it on every training assembly at the planning
threshold λ, and trains a fresh model on the usual training states plus every state that planner
scored and the training set lacks. Labels come from the ground truth: the valid next parts
(placing them still allows completion) where the simulator reaches the state, none where it does
not (a state reached through an infeasible placement completes nothing). This is DAgger (Ross et
al., 2011) with the ground truth as the expert and the new model trained on the aggregate.
Selected by `experiment=dagger` (`task.fit`); the first model's files stay in `<out_dir>/round_0`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import lightning.pytorch as pl
from omegaconf import DictConfig

from grace.cli.fit import train_module
from grace.domain.sample import LabelledAssembly
from grace.model.module import GraceModule
from grace.model.scoring import make_scorer
from grace.planning.visited import visited_states


def train_dagger(
    cfg: DictConfig,
    train: Sequence[LabelledAssembly],
    val: Sequence[LabelledAssembly],
    out_dir: str | Path,
    callbacks: Sequence[pl.Callback] = (),
    threshold: float = 0.5,
) -> GraceModule:
    """A module trained on the training states plus those its predecessor's planner visited."""
    first = train_module(cfg, train, val, Path(out_dir) / "round_0")
    scorer = make_scorer(first)
    extra = visited_states(scorer, train, threshold, str(cfg.datamodule.states))
    return train_module(cfg, train, val, out_dir, callbacks, extra_states=extra)
