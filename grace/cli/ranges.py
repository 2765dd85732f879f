"""The range of every numeric config value: one declaration per key, checked in one place.

Types come from the typed schemas (grace/cli/schemas.py); what a type cannot say (a seed numpy
refuses, a batch of 0, a negative learning rate or patience, a budget of 0 checks) is declared
here, one `Range` per config key as the command line writes it, and checked by
`grace.cli.values.check_ranges` before the run folder exists. The table is imported before
torch (the preflight refuses a bad value in about a second), so it names keys rather than
living beside the dataclasses, most of whose modules import torch. Every numeric field of every
schema has an entry (tests/cli/test_ranges.py fails on a field without one); a few untyped keys
of the shipped configs (the learning rate, the lr schedule, Optuna's sampler and pruner) have
one too. A list of numbers has the range of each of its elements. Why each range: the `why` of
its entry, and docs/operations.md, "Bad input".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from grace.domain.assembly import MIN_PARTS

SEED_MAX = 2**32 - 1
"""numpy's legacy generator, which Lightning's `seed_everything` seeds, takes [0, 2³² − 1]."""


@dataclass(frozen=True)
class Range:
    """[low, high], either end open (`open_low`, `open_high`) or infinite, plus `special`
    values with a meaning of their own (Lightning's −1: no limit). `why` says what the value
    does; `example` is the value the fix proposes (default: the lowest allowed)."""

    low: float = -math.inf
    high: float = math.inf
    why: str = ""
    open_low: bool = False
    open_high: bool = False
    special: tuple[float, ...] = ()
    example: float | None = None

    def holds(self, value: float) -> bool:
        """Whether `value` lies in the range (NaN never does)."""
        if value in self.special:
            return True
        above = value > self.low if self.open_low else value >= self.low
        below = value < self.high if self.open_high else value <= self.high
        return above and below

    def interval(self) -> str:
        """The range as written in an error message: `[1, ∞)`, `(0, 1]`, `[1, ∞) or -1`."""
        low = "−∞" if math.isinf(self.low) else number(self.low)
        high = "∞" if math.isinf(self.high) else number(self.high)
        left = "(" if self.open_low or math.isinf(self.low) else "["
        right = ")" if self.open_high or math.isinf(self.high) else "]"
        extra = "".join(f" or {number(v)}" for v in self.special)
        return f"{left}{low}, {high}{right}{extra}"

    def suggestion(self) -> float:
        """The value a fix proposes."""
        if self.example is not None:
            return self.example
        return self.low if math.isfinite(self.low) else self.high


def number(value: float) -> str:
    """`value` as a message writes it: whole numbers without a point, others in short form."""
    return str(int(value)) if float(value).is_integer() else f"{value:g}"


def at_least(low: float, why: str, **more: object) -> Range:
    return Range(low, why=why, **more)  # type: ignore[arg-type]


def above(low: float, why: str, example: float) -> Range:
    return Range(low, why=why, open_low=True, example=example)


def fraction(why: str, **more: object) -> Range:
    return Range(0, 1, why=why, **more)  # type: ignore[arg-type]


SEED = Range(0, SEED_MAX, "numpy's generators, as Lightning seeds them, take 0 to 2³² − 1")
SIZE = at_least(MIN_PARTS, "an assembly size in parts; one part has a single order to learn")
LAMBDA = fraction("a λ: step scores are probabilities")
FOLD = at_least(0, "a fold index of the run that trained the model, from 0")
MM = at_least(0, "a length in millimetres")
LENGTH = above(0, "a length in millimetres", 1)
SHARE = fraction("a probability")

RANGES: dict[str, Range] = {
    # The root config (grace/conf/config.yaml); first, so that a value the groups interpolate
    # (seed) is named by its own key.
    "seed": SEED,
    "threads": at_least(1, "threads per process; at most the machine's cores"),
    "train_size": SIZE,
    "test_size": SIZE,
    # dataset=generated (grace.data.store.GeneratedSource)
    "dataset.seed": SEED,
    "dataset.chunk_size": at_least(1, "assemblies per shard file"),
    "dataset.shard": at_least(0, "this process's share of the chunks, 0 to num_shards − 1"),
    "dataset.num_shards": at_least(1, "processes sharing the generation; 1: this one alone"),
    "dataset.workers": at_least(1, "generating processes on this machine"),
    "dataset.distinct_from": SEED,
    # protocol (grace.evaluation.protocols.ProtocolSettings)
    "protocol.folds": at_least(2, "cross-validation needs at least 2 folds"),
    "protocol.val_fraction": Range(
        0,
        1,
        "the share of training assemblies kept for validation; 1 would leave none to train on",
        open_high=True,
    ),
    "protocol.seed": SEED,
    "protocol.train_sizes": SIZE,
    "protocol.test_sizes": SIZE,
    "protocol.train_exclude": SIZE,
    "protocol.test_exclude": SIZE,
    # model (grace.model.module.GraceModule, grace.model.grace_pyg.NetConfig,
    # grace.graphs.encoding.GraphEncoding)
    "model.net.hidden": at_least(1, "the width of the network's features"),
    "model.net.surface_blocks": at_least(1, "GATv2 blocks over the surface graph"),
    "model.net.negative_slope": fraction("the LeakyReLU slope inside GATv2 attention"),
    "model.net.pe_dim": at_least(1, "features of a positional encoding"),
    "model.net.state_blocks": at_least(0, "surface blocks that see the state; 0: none"),
    "model.net.pair_readout": at_least(0, "the relational readout's width; 0: none"),
    "model.net.readout_rounds": at_least(1, "rounds of the relational readout"),
    "model.net.pair_geometry": at_least(0, "the pair geometry MLP's width; 0: none"),
    "model.net.extra_part_features": at_least(
        0, "part-node inputs beyond the paper's (model.graph.cell); 0: none"
    ),
    "model.graph.pe_dim": at_least(1, "features of a positional encoding"),
    "model.graph.part_id_range": at_least(
        MIN_PARTS,
        "part ids are drawn below it (at least the largest assembly's parts); null: 0..N-1",
        example=24,
    ),
    "model.graph.distance_scale": above(
        0, "millimetres per unit of a surface distance fed to the network", 100
    ),
    "model.delta": at_least(0, "the weight of the placed-part regulariser (paper Eq. 4)"),
    "model.placeable_pos_weight": above(0, "the weight of positive placeable labels", 1),
    "model.seed": SEED,
    "model.loss.rank_weight": at_least(0, "the weight of the listwise ranking term; 0: none"),
    "model.optimizer.lr": above(0, "a learning rate", 0.0022),
    "model.scheduler.eta_min": at_least(0, "the cosine schedule's last learning rate"),
    "model.scheduler.factor": Range(
        0,
        1,
        "what a plateau multiplies the learning rate by",
        open_low=True,
        open_high=True,
        example=0.5,
    ),
    "model.scheduler.patience": at_least(0, "epochs without improvement before the lr drops"),
    # datamodule (grace.graphs.datamodule.StateDataModule)
    "datamodule.batch_size": at_least(1, "states per batch"),
    "datamodule.seed": SEED,
    "datamodule.dead_end_target": Range(
        0,
        0.5,
        "0 keeps the labels; ≥ 0.5 would count a dead end as a valid step",
        open_high=True,
    ),
    "datamodule.dead_end_weight": at_least(0, "the loss weight of a dead-end state; 1: as any"),
    # trainer (lightning.pytorch.Trainer)
    "trainer.num_nodes": at_least(1, "machines the training runs on"),
    "trainer.max_epochs": at_least(1, "0 trains nothing and reports an untrained model"),
    "trainer.min_epochs": at_least(0, "epochs before early stopping may end a fit"),
    "trainer.max_steps": at_least(1, "optimiser steps; -1: no limit", special=(-1,)),
    "trainer.min_steps": at_least(0, "steps before early stopping may end a fit"),
    "trainer.check_val_every_n_epoch": at_least(1, "epochs between validations"),
    "trainer.num_sanity_val_steps": at_least(
        0, "batches checked before training; -1: all", special=(-1,)
    ),
    "trainer.log_every_n_steps": at_least(1, "steps between logged rows"),
    "trainer.accumulate_grad_batches": at_least(1, "batches per optimiser step"),
    "trainer.reload_dataloaders_every_n_epochs": at_least(0, "0: never"),
    "trainer.gradient_clip_val": at_least(0, "the largest gradient norm; 0 or null: no clipping"),
    # callbacks
    "callbacks.early_stopping.min_delta": at_least(0, "the smallest change that improves"),
    "callbacks.early_stopping.patience": at_least(0, "epochs without improvement before a stop"),
    "callbacks.early_stopping.stopping_threshold": Range(why="a value of the monitored metric"),
    "callbacks.early_stopping.divergence_threshold": Range(why="a value of the monitored metric"),
    "callbacks.model_checkpoint.save_top_k": Range(
        1,
        1,
        "checkpoints/best.ckpt holds the best weights, loaded back after training and by "
        "task=plan (0 keeps none; more keep other epochs under other names)",
    ),
    "callbacks.model_checkpoint.every_n_train_steps": at_least(0, "0: not by steps"),
    "callbacks.model_checkpoint.every_n_epochs": at_least(0, "0: not by epochs"),
    "logger.csv.flush_logs_every_n_steps": at_least(1, "steps between writes of the log"),
    # tune (grace.cli.tune_space.TuneConfig)
    "tune.n_trials": at_least(1, "trials this process runs; 0 would run none"),
    "tune.timeout": above(0, "seconds after which no trial starts; null: no limit", 3600),
    "tune.folds": at_least(1, "folds trained per trial; null: all"),
    "tune.sampler.n_startup_trials": at_least(0, "random trials before TPE takes over"),
    "tune.pruner.n_startup_trials": at_least(0, "trials before the pruner prunes"),
    "tune.pruner.n_warmup_steps": at_least(0, "epochs of a trial before it can be pruned"),
    # planner (grace.planning.search.VerifiedSearch, grace.planning.topk.TopKListing)
    "planner.k": at_least(1, "orders task=plan returns"),
    "planner.threshold": LAMBDA,
    "planner.max_expansions": at_least(1, "prefixes the unbounded listing expands"),
    "planner.touch_tolerance": MM,
    "planner.max_checks": at_least(1, "simulator step checks; null: unlimited"),
    "threshold.floor": fraction("the lowest score that opens a branch (scores are probabilities)"),
    "planner.max_seconds": above(0, "seconds of search; null: unlimited", 10),
    "planner.exhaustive_parts": at_least(0, "parts up to which the brute force decides; 0: never"),
    "planner.exhaustive_after": at_least(0, "checks per part the search spends before it"),
    # task (the TaskSettings of each grace/tasks/<name>.py)
    "task.threshold": LAMBDA,
    # after task.threshold, which it follows by default: a bad λ is named where it was given
    "threshold.level": LAMBDA,
    "task.ks": at_least(1, "the k of P@k"),
    "task.fold_jobs": at_least(1, "folds trained side by side"),
    "task.recording.per_size": at_least(0, "test assemblies recorded per size; 0: none"),
    "task.recording.top_k": at_least(1, "sequences listed per recorded assembly"),
    "task.recording.truth_orders": at_least(0, "ground-truth orders listed per assembly"),
    "task.fold": FOLD,
    "task.threads": at_least(1, "torch threads of a planning task; at most the machine's cores"),
    "task.data_seed": SEED,
    "task.draw_seed": SEED,
    "task.rounds": at_least(0, "self-training rounds; 0: the original training set only"),
    "task.patience": at_least(1, "judged rounds without a better one before a stop; null: R"),
    "task.probe_checks": at_least(0, "checks per probed step's sub-search; null: no probe"),
    "task.train_size": SIZE,
    "task.infer_size": SIZE,
    "task.assemblies": at_least(1, "assemblies per size"),
    "task.train_steps": at_least(1, "timed optimiser steps"),
    "task.infer_calls": at_least(1, "timed calls"),
    "task.prefix_passes": at_least(1, "timed forward passes"),
    "task.profile_epochs": at_least(1, "profiled epochs"),
    "task.topview": at_least(0, "assemblies drawn; 0: none"),
    "task.budgets": at_least(1, "step-check budgets in multiples of the part count"),
    "task.max_seconds": above(0, "seconds per planner and assembly; null: unlimited", 60),
    "task.unverified_max_expansions": at_least(1, "prefixes the unbounded listing expands"),
    "task.sizes": SIZE,
    "task.per_size": at_least(1, "assemblies per size"),
    "task.moved_per_size": at_least(1, "assemblies per size moved by each shift"),
    "task.moves": Range(-1000, 1000, "a shift on the table in millimetres", example=50),
    "task.states_per_assembly": at_least(1, "states per assembly"),
    "task.test_fraction": Range(
        0, 1, "the share of each size held out for testing", open_high=True
    ),
    "task.val_fraction": Range(0, 1, "the share of the rest kept for validation", open_high=True),
    # simulator (grace.simulation.cell_config; docs/world.md)
    "simulator.cell.table.size": LENGTH,
    "simulator.cell.arm.link_lengths": LENGTH,
    "simulator.cell.arm.joint_limits": Range(
        0, 180, "a joint's ± limit in degrees", open_low=True, example=170
    ),
    "simulator.cell.arm.link_radii": LENGTH,
    "simulator.cell.gripper.palm_height": LENGTH,
    "simulator.cell.gripper.palm_width": LENGTH,
    "simulator.cell.gripper.palm_depth": LENGTH,
    "simulator.cell.gripper.finger_thickness": LENGTH,
    "simulator.cell.gripper.finger_width": LENGTH,
    "simulator.cell.gripper.finger_length": LENGTH,
    "simulator.cell.gripper.max_opening": LENGTH,
    "simulator.cell.gripper.grasp_height": MM,
    "simulator.cell.gripper.bracket_grip_depth": MM,
    "simulator.cell.clamp.grid": LENGTH,
    "simulator.cell.grasp_fractions": fraction("a position along a profile, as a share of it"),
    "simulator.cell.touch_tolerance": MM,
    "simulator.cell.arm_sample_step": LENGTH,
    "simulator.cell.max_branches": at_least(1, "IK branches tried per arm (4 exist)"),
    "simulator.cell.max_parts": at_least(MIN_PARTS, "part slots of the compiled cell"),
    "simulator.cell.track": Range(
        why="a carriage position along the track, mm either side of the arm's base"
    ),
    "simulator.generator.profile_300_share": SHARE,
    "simulator.generator.flush_share": SHARE,
    "simulator.generator.bracket_share": SHARE,
    "simulator.generator.gap_mm": MM,
    "simulator.generator.position_grid_mm": LENGTH,
    "simulator.generator.work_area": LENGTH,
    "simulator.generator.max_attempts": at_least(1, "growth attempts per try"),
    "simulator.generator.max_restarts": at_least(1, "tries before the generator gives up"),
    "simulator.generator.section_parts": at_least(0, "parts per section; 0: frames grow whole"),
    "simulator.generator.section_gap_mm": MM,
    "simulator.generator.frame_area": LENGTH,
    "simulator.motion.slide_length": MM,
    "simulator.motion.slide_lead": MM,
    "simulator.motion.approach_clearance": MM,
}
