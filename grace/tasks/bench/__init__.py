"""`python -m grace task=bench`: training and inference speed of the PyG and fast paths.

Side by side in one run, same weights, `cfg.threads` threads:
- training: optimiser steps on batches of ≈`datamodule.batch_size` A5 state graphs, timed from the
  per-assembly encodings (collation into PyG graphs or padded tensors included) through the
  backward pass and Adam step; figure = state graphs per second;
- inference: one A7 state per call, end to end from the Assembly (encoding, graph, forward);
  "cold" empties the scorer's per-assembly cache before every call, "warm" reuses the
  per-assembly cache that planning over many states of one assembly enjoys (fast path only;
  the PyG path has no shared work); with `task.compile_backend` also the fast path through
  torch.compile (model/impl=compiled), beside the seconds its first calls spent compiling;
- planning (grace.planning.prefix_cost): scoring every order of one A7 assembly via its
  distinct states versus the per-prefix recursion, with each path's scorer (untrained weights:
  timing only; prefix passes capped at `task.prefix_passes` and extrapolated);
- evaluation (grace.evaluation.evaluate): milliseconds per A7 assembly of everything an
  experiment computes for one policy on one test assembly (every state scored, the λ sweep of the
  sequence AUC, P@k, both step AUCs, the feasibility schemes, the first false steps), for GRACE
  on the fast path (untrained weights) and every baseline of grace.evaluation.baselines.
Writes `bench.json` into the run's output folder and returns the fast/PyG training speed-up.

`task.profile=true` instead trains `task.profile_epochs` epochs of the experiment's first fold
on the configured data and model and writes where their time goes (grace/model/profiling.py)
to `profile.json` (grace/tasks/bench/epoch_profile.py).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch
from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig

from grace.cli.runner import TaskSettings
from grace.data.atomic import strict_json, write_json_atomic, write_text_atomic
from grace.evaluation.baselines import BASELINES
from grace.evaluation.evaluation_timing import evaluate_ms_per_assembly
from grace.graphs.datamodule import StateDataset
from grace.model.grace_pyg import count_parameters
from grace.model.impls import FastImpl, NetImpl, PygImpl
from grace.model.scoring import make_scorer
from grace.model.timing import (
    compiled_inference,
    feasible_assemblies,
    infer_ms_per_state,
    inference_table,
    train_graphs_per_s,
)
from grace.planning.prefix_cost import planner_benchmark
from grace.roles import RUN
from grace.tasks.bench.epoch_profile import profile_epochs

log = logging.getLogger(__name__)

IMPLS: tuple[NetImpl, ...] = (PygImpl(), FastImpl())
"""Both implementations, measured side by side on the same weights."""


@dataclass
class BenchSettings(TaskSettings):
    """Schema of `task=bench` (values in grace/conf/task/bench.yaml)."""

    train_size: int = field(default=MISSING, metadata=RUN)
    infer_size: int = field(default=MISSING, metadata=RUN)
    assemblies: int = field(default=MISSING, metadata=RUN)
    train_steps: int = field(default=MISSING, metadata=RUN)
    infer_calls: int = field(default=MISSING, metadata=RUN)
    prefix_passes: int = field(default=MISSING, metadata=RUN)
    compile_backend: str | None = field(default=MISSING, metadata=RUN)
    profile: bool = field(default=MISSING, metadata=RUN)
    profile_epochs: int = field(default=MISSING, metadata=RUN)


def run(cfg: DictConfig) -> float:
    if cfg.task.profile:
        return profile_epochs(cfg)
    out_dir = Path(cfg.paths.output_dir)
    rng = np.random.default_rng(int(cfg.seed))
    train_size, infer_size = int(cfg.task.train_size), int(cfg.task.infer_size)
    simulator, count = instantiate(cfg.simulator), int(cfg.task.assemblies)
    train = feasible_assemblies(simulator, train_size, count, rng)
    infer = feasible_assemblies(simulator, infer_size, count, rng)
    module = instantiate(cfg.model)
    torch.set_num_threads(int(cfg.threads))
    batch_size = int(cfg.datamodule.batch_size)
    states = cfg.datamodule.states
    dataset = StateDataset(train, module.enc, states, batch_size, True, int(cfg.seed))
    state = {k: v.clone() for k, v in module.state_dict().items()}
    speed, infer_cold, infer_warm = {}, {}, {}
    calls = int(cfg.task.infer_calls)
    for impl in IMPLS:
        module.load_state_dict(state)
        module.impl = impl
        speed[impl.name] = train_graphs_per_s(
            module, dataset, batch_size, int(cfg.task.train_steps)
        )
        module.eval()
        cold = infer_ms_per_state(module, infer, impl, calls, False)
        infer_cold[impl.name] = {str(infer_size): cold}
        log.info(
            "%s: %.0f graphs/s training, %.3f ms per A%d state",
            *(impl.name, speed[impl.name], cold, infer_size),
        )
    # Only the fast path shares work between the states of an assembly.
    warm = infer_ms_per_state(module, infer, FastImpl(), calls, True)
    infer_warm["fast"] = {str(infer_size): warm}
    compile_s = None
    if cfg.task.compile_backend:
        compile_s, cold, warm = compiled_inference(module, infer, calls, cfg.task.compile_backend)
        infer_cold["compiled"] = {str(infer_size): cold}
        infer_warm["compiled"] = {str(infer_size): warm}
    planning = {
        impl.name: planner_benchmark(
            make_scorer(module, impl), infer[0].assembly, prefix_passes=int(cfg.task.prefix_passes)
        )
        for impl in IMPLS
    }
    policies = {"GRACE": make_scorer(module, FastImpl())}
    policies.update({name: make(int(cfg.seed)) for name, make in BASELINES.items()})
    evaluation = {
        name: {str(infer_size): evaluate_ms_per_assembly(scorer, infer)}
        for name, scorer in policies.items()
    }
    result = {
        "params": count_parameters(module.net),
        "train_graphs_per_s": speed,
        "infer_ms_per_state": infer_cold,
        "infer_ms_per_state_warm": infer_warm,
        "compile_s": compile_s,
        "speedup_train": speed["fast"] / speed["pyg"],
        "planning": planning,
        "evaluate_ms_per_assembly": evaluation,
        "threads": torch.get_num_threads(),
        "infer_calls": calls,
        "batch_size": batch_size,
        "assemblies": {str(train_size): len(train), str(infer_size): len(infer)},
    }
    write_json_atomic(out_dir / "bench.json", result)
    write_text_atomic(out_dir / "inference.md", inference_table(result))
    print(strict_json(result))
    return result["speedup_train"]
