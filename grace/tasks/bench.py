"""`python -m grace task=bench`: training and inference speed of the PyG and fast paths.

Side by side in one run, same weights, `cfg.threads` threads:
- training: optimiser steps on batches of ≈`datamodule.batch_size` A5 state graphs, timed from the
  per-assembly encodings (collation into PyG graphs or padded tensors included) through the
  backward pass and Adam step; figure = state graphs per second;
- inference: one A7 state per call, end to end from the Assembly (encoding, graph, forward);
  "cold" empties the scorer's per-assembly cache before every call, "warm" reuses the
  per-assembly cache that planning over many states of one assembly enjoys (fast path only;
  the PyG path has no shared work);
- planning (grace.planning.bench): scoring every order of one A7 assembly via its
  distinct states versus the per-prefix recursion, with each path's scorer (untrained weights:
  timing only; prefix passes capped at `task.prefix_passes` and extrapolated);
- evaluation (grace.evaluation.evaluate): milliseconds per A7 assembly of everything an
  experiment computes for one policy on one test assembly (every state scored, the λ sweep of the
  sequence AUC, P@k, both step AUCs, the feasibility schemes, the first false steps), for GRACE
  on the fast path (untrained weights) and every baseline of grace.evaluation.baselines.
Writes `bench.json` into the run's output folder and returns the fast/PyG training speed-up.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig

from grace.data.atomic import strict_json, write_json_atomic
from grace.domain.sample import LabelledAssembly
from grace.evaluation.baselines import BASELINES
from grace.evaluation.evaluate import evaluate_by_size
from grace.graphs.datamodule import AssemblyBatchSampler, StateDataset, merge_chunks
from grace.model.grace_pyg import count_parameters
from grace.model.impls import FastImpl, NetImpl, PygImpl
from grace.model.module import GraceModule
from grace.model.scoring import make_scorer
from grace.planning.bench import planner_benchmark
from grace.planning.sequences import Scorer
from grace.tasks.runner import TaskSettings

log = logging.getLogger(__name__)

IMPLS: tuple[NetImpl, ...] = (PygImpl(), FastImpl())
"""Both implementations, measured side by side on the same weights."""


@dataclass
class BenchSettings(TaskSettings):
    """Schema of `task=bench` (values in grace/conf/task/bench.yaml)."""

    train_size: int = MISSING
    infer_size: int = MISSING
    assemblies: int = MISSING
    train_steps: int = MISSING
    infer_calls: int = MISSING
    prefix_passes: int = MISSING


def bench_assemblies(
    cfg: DictConfig, size: int, rng: np.random.Generator
) -> list[LabelledAssembly]:
    """`task.assemblies` feasible assemblies of `size` from the configured simulator."""
    simulator = instantiate(cfg.simulator)
    out: list[LabelledAssembly] = []
    for _ in range(50 * int(cfg.task.assemblies)):
        sample = simulator.sample(size, rng)
        if sample.truth.feasible:
            out.append(sample)
        if len(out) == int(cfg.task.assemblies):
            return out
    raise RuntimeError(f"bench: the simulator gave too few feasible A{size} assemblies")


def _batches(dataset: StateDataset, batch_size: int) -> list[list[int]]:
    """The training sampler's batches in chunk order, without a short last one (timed steps
    should all hold ≈`batch_size` states)."""
    sizes = dataset.chunk_sizes()
    packed = AssemblyBatchSampler(sizes, batch_size, shuffle=False, seed=0)
    batches = [b for b in packed if sum(sizes[k] for k in b) >= batch_size]
    if not batches:
        raise RuntimeError("bench: too few states for one training batch; raise task.assemblies")
    return batches


def train_graphs_per_s(
    module: GraceModule, dataset: StateDataset, batch_size: int, steps: int
) -> float:
    """State graphs per second of full training steps (collate, forward, backward, Adam).

    The median over steps: the machine is shared, and one preempted step should not decide.
    """
    optimiser = torch.optim.Adam(module.parameters(), lr=1e-4)
    module.train()
    batches = _batches(dataset, batch_size)
    rates = []
    for step in range(steps + 1):
        items = [dataset[k] for k in batches[step % len(batches)]]
        start = time.perf_counter()
        batch = merge_chunks(dataset, module.impl.collate, items)
        loss = module.loss(batch, module(batch))
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        if step:  # the first step warms up allocators and lazy initialisation
            rates.append(batch.n_states / (time.perf_counter() - start))
    return float(np.median(rates))


def infer_ms_per_state(
    module: GraceModule, samples: list[LabelledAssembly], impl: NetImpl, calls: int, warm: bool
) -> float:
    """Median milliseconds per single-state scorer call on the non-final states of `samples`."""
    pairs = [(s.assembly, int(st)) for s in samples for st in s.truth.states[:-1]]
    scorer = make_scorer(module, impl)
    for assembly, state in pairs[:3]:
        scorer(assembly, np.array([state]))
    times = []
    for k in range(calls):
        assembly, state = pairs[k % len(pairs)]
        if not warm:
            scorer.clear()
        start = time.perf_counter()
        scorer(assembly, np.array([state]))
        times.append(time.perf_counter() - start)
    return 1000.0 * float(np.median(times))


def evaluate_ms_per_assembly(scorer: Scorer, samples: list[LabelledAssembly]) -> float:
    """Milliseconds per assembly of one policy's whole evaluation on `samples`."""
    start = time.perf_counter()
    evaluate_by_size(scorer, samples)
    return 1000.0 * (time.perf_counter() - start) / len(samples)


def run(cfg: DictConfig) -> float:
    out_dir = Path(cfg.paths.output_dir)
    rng = np.random.default_rng(int(cfg.seed))
    train_size, infer_size = int(cfg.task.train_size), int(cfg.task.infer_size)
    train = bench_assemblies(cfg, train_size, rng)
    infer = bench_assemblies(cfg, infer_size, rng)
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
        "speedup_train": speed["fast"] / speed["pyg"],
        "planning": planning,
        "evaluate_ms_per_assembly": evaluation,
        "threads": torch.get_num_threads(),
        "batch_size": batch_size,
        "assemblies": {str(train_size): len(train), str(infer_size): len(infer)},
    }
    write_json_atomic(out_dir / "bench.json", result)
    print(strict_json(result))
    return result["speedup_train"]
