"""`python -m grace task=plan ckpt=<run folder or .ckpt> assembly=<raw folder or assembly.spec>`.

Plans one assembly with a kept model and `planner=` (docs/planning.md): the verified search
(the default, grace/planning/search.py: only orders the simulator accepts at every step, or
"infeasible", or "not found within budget") or the top-k listing of Algorithm 1
(`planner=topk`, grace/planning/topk.py: the `k` most probable sequences, each checked step by
step afterwards). Either answers a checked plan (grace/planning/plans.py), written as plan.json
into the run folder (grace/planning/plan_file.py) and printed; with `task.recording=true`,
plan.rrd after it (rerun is imported only then). Planning imports neither Lightning nor PyG
(grace/model/checkpoints.py).

The model is rebuilt from the `config.yaml` kept beside its checkpoint (<fold>/config.yaml, see
grace/model/checkpoints.py), and the checkpoint's weights must fit it exactly: a checkpoint made for
another config stops with one line naming both files.
"""

from __future__ import annotations

import gc
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import ClassVar

from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig

from grace.cli.runner import TaskSettings
from grace.data.raw_format import read_assembly
from grace.model.checkpoints import load_model
from grace.model.kept import find_checkpoint
from grace.model.scoring import make_scorer
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.plan_file import write_plan
from grace.planning.plan_views import plan_view
from grace.planning.plans import Plan
from grace.planning.topk import lazy_scores
from grace.roles import PLANNING, RUN


@dataclass
class PlanSettings(TaskSettings):
    """Schema of `task=plan` (values in grace/conf/task/plan.yaml)."""

    reads: ClassVar[tuple[str, ...] | None] = ("planner",)
    # a run folder (train or experiment) or a .ckpt file
    ckpt: str | None = field(default=MISSING, metadata=PLANNING)
    # a raw assembly folder or an assembly.spec file
    assembly: str | None = field(default=MISSING, metadata=PLANNING)
    # which fold's model of an experiment run folder
    fold: int = field(default=0, metadata=PLANNING)
    # plan.rrd too, written after plan.json and the printed answer
    recording: bool = field(default=False, metadata=PLANNING)
    # the model's training cell; false: `simulator=` (e.g. large_frames)
    kept_world: bool = field(default=True, metadata=PLANNING)
    # torch threads of this task: the root `threads` follows it unless given
    threads: int = field(default=1, metadata=RUN)


def headline(plan: Plan) -> str:
    """The answer's first line: how the planner ended, and what it cost."""
    start = f"{plan.name}: {plan.n_parts} parts"
    if plan.listing is not None:
        feas = plan.listing.feasibility
        return f"{start}, feasibility score {'n/a' if feas is None else f'{feas:.4f}'}"
    cost = f"{plan.search.checks} simulator step checks, {plan.seconds:.2f} s"
    if plan.outcome == "verified":
        return f"{start}, {len(plan.orders)} verified order(s) ({cost})"
    if plan.outcome == "infeasible":
        return f"{start}, infeasible: every order refuted ({cost})"
    budget = (
        f"planner.max_checks={plan.planner.get('max_checks')}, "
        f"planner.max_seconds={plan.planner.get('max_seconds')}"
    )
    return f"{start}, not found within budget ({budget}; {cost})"


def answer(plan: Plan) -> list[str]:
    """The printed answer: the headline, then each order with the simulator's verdict (1-based
    step numbers; plan.json's are 0-based), then why the listing may be short."""
    lines = [headline(plan)]
    for order in plan.orders:
        sim = order.simulator
        verdict = "every step feasible"
        if not sim.feasible:
            step = sim.failing_step
            verdict = f"fails at step {step + 1} (part {order.sequence[step]}): {sim.reason}"
        text = " ".join(str(p) for p in order.sequence)
        lines.append(f"{order.rank:3d}. {text}  p={order.probability:.4g}  simulator: {verdict}")
    listing, settings = plan.listing, plan.planner
    if listing is not None and listing.stopped_by_budget:
        lines.append(
            f"{len(plan.orders)} of {settings['k']} sequences found within budget (planner."
            f"max_expansions={settings['max_expansions']}, planner.max_seconds="
            f"{settings['max_seconds']})"
        )
    elif listing is not None and not plan.orders:
        lines.append(f"no complete sequence has every step scoring ≥ {settings['threshold']}")
    return lines


def run(cfg: DictConfig) -> float | None:
    """Plan `task.assembly` with the model of `task.ckpt`; return the top-k listing's
    feasibility score (None for the verified search)."""
    out_dir = Path(cfg.paths.output_dir)
    begin = time.perf_counter()
    ckpt = find_checkpoint(cfg.task.ckpt, int(cfg.task.fold))
    assembly, truth = read_assembly(cfg.task.assembly)
    module, kept = load_model(ckpt)
    simulator = instantiate(kept.simulator if cfg.task.kept_world else cfg.simulator)
    planner = instantiate(cfg.planner)
    scorer = make_scorer(module)
    load_seconds = time.perf_counter() - begin
    # What is loaded (torch, MuJoCo, Hydra: about a million objects) never becomes garbage;
    # frozen, it stays out of the collector's full walks, which a search's many small
    # allocations would otherwise trigger dozens of times (tens of ms each).
    gc.freeze()
    steps = SimulatorSteps(simulator, assembly)
    plan = planner.checked_plan(scorer, assembly, steps, truth)
    sources = {"checkpoint": str(ckpt), "assembly": str(cfg.task.assembly)}
    plan = replace(plan, sources={**sources, "load_seconds": load_seconds})
    write_plan(out_dir / "plan.json", plan)
    print("\n".join(answer(plan)))
    print(
        f"planned and checked in {plan.seconds:.2f} s (loading {load_seconds:.2f} s); "
        f"plan.json in {out_dir}",
        flush=True,
    )
    if cfg.task.recording:
        # rerun loads only to record
        from grace.visualisation.search_recording import write_plan_recording

        view = plan_view("plan", plan, steps.checker, lazy_scores(scorer, assembly), truth)
        write_plan_recording(view, out_dir / "plan.rrd", out_dir.name)
        print(f"plan.rrd in {out_dir}")
    return plan.listing.feasibility if plan.listing is not None else None
