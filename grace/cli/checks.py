"""Checks of a composed config that need no data: run before anything is generated or loaded.

Types are checked by the typed schemas when the config is composed (grace/cli/schemas.py),
ranges by grace/cli/values.py; here come the checks across keys and the input files a run reads
first: the protocol's sizes are in the data set, every fold gets test and training assemblies,
no assembly has fewer than two parts, the shard is one of the shards, a kept model's checkpoint
and config and the assembly to plan are usable, and overridden options that the chosen protocol
ignores. The data set's size → count is known up front (`dataset.sizes` of a generated set; the
cached import of a raw one), so a bad combination fails in a second, not after generation.
"""

from __future__ import annotations

import shlex
from collections.abc import Mapping, Sequence

from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from grace.cli.signals import held_while_loading
from grace.cli.values import check_paths, check_ranges
from grace.data.raw_format import read_assembly
from grace.domain.assembly import MIN_PARTS
from grace.errors import UserError
from grace.evaluation.protocols import check_fold_sizes, protocol_sizes
from grace.model.kept import find_checkpoint, kept_config

CROSS_VALIDATED = ("experiment", "feasibility")
"""Tasks that split the data set into the folds of `protocol`."""

TRAINED = (*CROSS_VALIDATED, "train", "tune")
"""Tasks that train the network on the data set."""

PROTOCOL_KEYS = ("train_size", "test_size")
"""Top-level keys that only the protocols that interpolate them use."""


def _list(node: object) -> list[int] | None:
    return None if node is None else [int(v) for v in OmegaConf.to_object(node)]


def protocol_split(proto: DictConfig, available: Sequence[int]) -> tuple[list[int], list[int]]:
    """Train and test sizes of the configured protocol `proto` over the `available` sizes."""
    return protocol_sizes(
        proto.name,
        available,
        _list(proto.train_sizes),
        _list(proto.test_sizes),
        _list(proto.train_exclude) or [],
        _list(proto.test_exclude) or [],
    )


def ignored_options(cfg: DictConfig, overrides: list[str]) -> list[str]:
    """Warnings for overrides of `PROTOCOL_KEYS` that the chosen protocol does not read (none
    for a task without folds)."""
    if cfg.task.name not in CROSS_VALIDATED:
        return []
    given = {o.split("=", 1)[0].lstrip("+~"): o for o in overrides if "=" in o}
    used = OmegaConf.to_yaml(cfg.protocol, resolve=False)
    return [
        f"{given[key]} is ignored by protocol={cfg.protocol.name} (it does not use {key}); "
        f"fix: drop it, or choose a protocol that uses it (docs/protocols.md)"
        for key in PROTOCOL_KEYS
        if key in given and f"${{{key}}}" not in used
    ]


def check_config(cfg: DictConfig) -> None:
    """Raise a UserError (one line) for a config that cannot run."""
    check_ranges(cfg)
    check_paths(cfg)
    check_shards(cfg)
    check_model_inputs(cfg)
    check_assembly_sizes(_sizes(OmegaConf.select(cfg, "dataset.sizes")))
    with held_while_loading():  # the source's module may import torch (tests' fakes do)
        source = instantiate(cfg.dataset)
    if hasattr(source, "check_sizes"):  # a generated set: its sizes, before any generation
        source.check_sizes()
        source.check_files()  # and what in its folder a run cannot repair
    if cfg.task.name not in TRAINED:
        return
    counts = source.counts() if hasattr(source, "counts") else None
    if counts is None:
        return
    check_assembly_sizes(counts)
    if cfg.task.name in CROSS_VALIDATED:
        proto = cfg.protocol
        train, test = protocol_split(proto, sorted(counts))
        check_fold_sizes(
            proto.name, counts, train, test, int(proto.folds), float(proto.val_fraction)
        )


def _sizes(node: object) -> dict[int, int]:
    """`dataset.sizes` as {size: count} where it is a mapping of integers (else {}: the data
    set's own check names what is wrong with it)."""
    if not OmegaConf.is_dict(node):
        return {}
    try:
        return {int(k): int(v) for k, v in OmegaConf.to_container(node, resolve=True).items()}
    except (TypeError, ValueError, OmegaConfBaseException):
        return {}


def check_assembly_sizes(counts: Mapping[int, int]) -> None:
    """A UserError for sizes below MIN_PARTS: one part has a single order to learn, and the
    network normalises each state's part features over its parts."""
    small = sorted(size for size in counts if size < MIN_PARTS)
    if not small:
        return
    kept = {size: n for size, n in sorted(counts.items()) if size >= MIN_PARTS}
    fix = shlex.quote(f"dataset.sizes={kept}") if kept else "larger assemblies (e.g. scale=smoke)"
    raise UserError(
        f"the data set holds assemblies of {small} part(s), fewer than the {MIN_PARTS} an order "
        f"needs to be learnt (dataset.sizes); fix: {fix}"
    )


def check_shards(cfg: DictConfig) -> None:
    """`dataset.shard` names one of the `dataset.num_shards` shares of the generation."""
    shard, shards = (OmegaConf.select(cfg, f"dataset.{key}") for key in ("shard", "num_shards"))
    if isinstance(shard, int) and isinstance(shards, int) and shard >= shards:
        raise UserError(
            f"dataset.shard={shard} is not below dataset.num_shards={shards}; fix: "
            f"dataset.shard=0 to {shards - 1} (one per process of the {shards})"
        )


def check_model_inputs(cfg: DictConfig) -> None:
    """A task that reads a kept model (`task.ckpt`) gets a checkpoint beside a readable config,
    and one that plans an assembly (`task.assembly`) gets an assembly of at least MIN_PARTS
    parts that the cell it is planned in can hold (simulator.cell.max_parts: of the kept
    config, or of this one with `task.kept_world=false`)."""
    task = cfg.task
    if "ckpt" not in task:
        return
    for key, what in (("ckpt", "<run folder or .ckpt>"), ("assembly", "<raw folder or .spec>")):
        if key in task and not task[key]:
            raise UserError(f"task={task.name} needs {key}=; fix: add {key}={what}")
    ckpt = find_checkpoint(task.ckpt, int(task.get("fold", 0)))
    _, kept = kept_config(ckpt)
    if task.get("assembly") is None:  # a task without one (given empty: refused above)
        return
    assembly, _ = read_assembly(task.assembly)
    world = kept if task.get("kept_world", True) else cfg
    n, slots = assembly.n_parts, OmegaConf.select(world, "simulator.cell.max_parts")
    if n < MIN_PARTS:
        raise UserError(
            f"assembly={task.assembly}: {n} part; planning needs {MIN_PARTS} or more (one part "
            f"has a single order); fix: an assembly of {MIN_PARTS} parts or more"
        )
    if isinstance(slots, int) and n > slots:
        raise UserError(
            f"assembly={task.assembly}: {n} parts, but the cell it is planned in has {slots} "
            f"part slots (simulator.cell.max_parts, docs/world.md); fix: an assembly of at most "
            f"{slots} parts, or task.kept_world=false simulator=large_frames (up to 50 parts, "
            "docs/planning.md)"
        )
