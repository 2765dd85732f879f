"""Timing of the network's two implementations (task=bench): training steps and single-state
inference, on the same weights; and the planner's scoring of one state's removals on a large
frame (`python -m grace.model.timing`); figures, not tests."""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
import torch

from grace.data.raw_format import read_assembly
from grace.domain.assembly import Assembly
from grace.domain.sample import LabelledAssembly
from grace.graphs.datamodule import AssemblyBatchSampler, StateDataset, merge_chunks
from grace.model.checkpoints import load_model
from grace.model.impls import CompiledImpl, NetImpl
from grace.model.kept import find_checkpoint
from grace.model.module import GraceModule
from grace.model.scoring import Scorer, make_scorer


def feasible_assemblies(
    simulator: Any, size: int, count: int, rng: np.random.Generator
) -> list[LabelledAssembly]:
    """`count` feasible assemblies of `size` from `simulator` (its `sample(size, rng)`)."""
    out: list[LabelledAssembly] = []
    for _ in range(50 * count):
        sample = simulator.sample(size, rng)
        if sample.truth.feasible:
            out.append(sample)
        if len(out) == count:
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


def compiled_inference(
    module: GraceModule, samples: list[LabelledAssembly], calls: int, backend: str
) -> tuple[float, float, float]:
    """The fast path through torch.compile (`backend`): seconds its first single-state query
    spends (compiling, mostly), then median cold and warm ms per state as
    :func:`infer_ms_per_state` measures them."""
    impl = CompiledImpl(backend)
    sample = samples[0]
    start = time.perf_counter()
    make_scorer(module, impl)(sample.assembly, sample.truth.states[:1])
    compile_s = time.perf_counter() - start
    cold = infer_ms_per_state(module, samples, impl, calls, False)
    return compile_s, cold, infer_ms_per_state(module, samples, impl, calls, True)


def inference_table(bench: dict[str, Any]) -> str:
    """Markdown: median ms per single-state query of each path, cold (a new assembly) and warm
    (an assembly already seen), from `bench.json`'s figures."""
    cold, warm = bench["infer_ms_per_state"], bench["infer_ms_per_state_warm"]
    lines = ["| path | size | cold ms | warm ms |", "|---|---|---|---|"]
    for path, by_size in cold.items():
        for size, ms in by_size.items():
            hot = warm.get(path, {}).get(size)
            lines.append(
                f"| {path} | A{size} | {ms:.3f} | {'—' if hot is None else f'{hot:.3f}'} |"
            )
    if bench.get("compile_s") is not None:
        lines.append("")
        lines.append(
            f"The compiled path's first query took {bench['compile_s']:.1f} s (compiling)."
        )
    lines.append(f"{bench['threads']} thread(s); median of {bench['infer_calls']} calls.")
    return "\n".join(lines) + "\n"


def removal_ms(
    scorer: Scorer, assembly: Assembly, sizes: list[int], calls: int
) -> dict[int, float]:
    """Median ms of one expansion of the backward search (grace/planning/search.py,
    `removal_scores`): scoring every removal of a state of the assembly's first k parts, per k
    in `sizes`, the assembly's shared work cached as in a search."""
    out = {}
    for k in sizes:
        state = (1 << k) - 1
        rests = np.array([state & ~(1 << p) for p in range(k)], dtype=np.int64)
        scorer(assembly, rests)  # warm-up: the shared work and the allocator
        times = []
        for _ in range(calls):
            start = time.perf_counter()
            scorer(assembly, rests)
            times.append(time.perf_counter() - start)
        out[k] = 1e3 * float(np.median(times))
    return out


def main() -> None:
    """`python -m grace.model.timing <ckpt or run folder> <assembly.spec> [calls]`: the planner's
    scoring cost on a large frame, one thread (docs/planning.md, "Large frames")."""
    parser = argparse.ArgumentParser(prog="python -m grace.model.timing", description=main.__doc__)
    parser.add_argument("ckpt")
    parser.add_argument("assembly")
    parser.add_argument("calls", nargs="?", type=int, default=20)
    args = parser.parse_args()
    torch.set_num_threads(1)
    module, _ = load_model(find_checkpoint(args.ckpt, 0))
    assembly, _ = read_assembly(args.assembly)
    n = assembly.n_parts
    sizes = sorted({n, max(1, n // 2), max(1, n // 5)}, reverse=True)
    for k, ms in removal_ms(make_scorer(module), assembly, sizes, args.calls).items():
        print(f"{k} removals of {n} parts: {ms:.1f} ms (median of {args.calls})")


if __name__ == "__main__":
    main()
