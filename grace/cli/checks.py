"""Checks of a composed config that need no data: run before anything is generated or loaded.

Types are checked by the typed schemas when the config is composed (grace/cli/schemas.py);
here come the checks across keys: the protocol's sizes are in the data set, every fold gets test
and training assemblies, and overridden options that the chosen protocol ignores. The data set's
size → count is known up front (`dataset.sizes` of a generated set; the cached import of a raw
one), so a bad combination fails in a second, not after generation.
"""

from __future__ import annotations

from collections.abc import Sequence

from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf

from grace.cli.signals import held_while_loading
from grace.cli.values import check_bounds, check_paths
from grace.evaluation.protocols import check_fold_sizes, protocol_sizes

CROSS_VALIDATED = ("experiment", "feasibility")
"""Tasks that split the data set into the folds of `protocol`."""

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
    check_bounds(cfg)
    check_paths(cfg)
    with held_while_loading():  # the source's module may import torch (tests' fakes do)
        source = instantiate(cfg.dataset)
    if hasattr(source, "check_sizes"):  # a generated set: its sizes, before any generation
        source.check_sizes()
        source.check_files()  # and what in its folder a run cannot repair
    if cfg.task.name not in CROSS_VALIDATED:
        return
    counts = source.counts() if hasattr(source, "counts") else None
    proto = cfg.protocol
    if counts is not None:
        train, test = protocol_split(proto, sorted(counts))
        check_fold_sizes(
            proto.name, counts, train, test, int(proto.folds), float(proto.val_fraction)
        )
