"""Checks of single values in a composed config: numbers within their ranges, folders usable.

Run by the preflight (grace/cli/preflight.py) before the run folder exists, so a seed of -1, a
λ of 1.5 or a data folder that is a file stops the command in one line naming the key and the
fix, with nothing written; the same checks run again inside the run (grace/cli/runner.py).
Ranges and why: docs/operations.md, "Bad input".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from grace.data.folders import obstacle
from grace.errors import UserError


@dataclass(frozen=True)
class Bound:
    """`key` must lie in [low, high] (or [low, high) when `open_high`); absent keys pass."""

    key: str
    low: float
    high: float = math.inf
    open_high: bool = False
    fix: str = ""

    def interval(self) -> str:
        high = "∞" if math.isinf(self.high) else f"{self.high:g}"
        return f"[{self.low:g}, {high}{')' if self.open_high or math.isinf(self.high) else ']'}"


BOUNDS = (
    Bound("seed", 0, fix="seed=0 (any integer ≥ 0; numpy's generators take no negative seed)"),
    Bound("threads", 1, fix="threads=1 or more (at most the machine's cores)"),
    Bound("planner.k", 1, fix="planner.k=1 or more (how many orders task=plan returns)"),
    Bound("task.threshold", 0, 1, fix="a λ in [0, 1] (step scores are probabilities)"),
    Bound("planner.threshold", 0, 1, fix="a λ in [0, 1] (step scores are probabilities)"),
    Bound("threshold.floor", 0, 1, fix="a floor in [0, 1] (step scores are probabilities)"),
    Bound("trainer.max_epochs", 1, fix="trainer.max_epochs=1 or more (0 trains nothing)"),
    Bound(
        "datamodule.dead_end_target",
        0,
        0.5,
        open_high=True,
        fix="a target in [0, 0.5) (0 keeps the labels; ≥ 0.5 would count a dead end as valid)",
    ),
)
"""The numbers the preflight checks (grace/graphs/datamodule.py checks dead_end_target too, for
callers outside the command line)."""


def check_bounds(cfg: DictConfig) -> None:
    """A UserError naming the first key of BOUNDS whose value lies outside its range."""
    for bound in BOUNDS:
        value = OmegaConf.select(cfg, bound.key, throw_on_resolution_failure=False)
        if not isinstance(value, int | float) or isinstance(value, bool):
            continue
        above = value >= bound.high if bound.open_high else value > bound.high
        if value < bound.low or above or math.isnan(value):
            raise UserError(f"{bound.key}={value} is outside {bound.interval()}; fix: {bound.fix}")


def check_override_bounds(overrides: list[str]) -> None:
    """:func:`check_bounds` on the command line's own `key=value` overrides of BOUNDS' keys:
    the keys of groups whose schemas load with torch are refused in a second, before that."""
    keys = {bound.key for bound in BOUNDS}
    mine = [o.removeprefix("++").removeprefix("+") for o in overrides]
    check_bounds(OmegaConf.from_dotlist([o for o in mine if o.split("=", 1)[0] in keys]))


FOLDERS = (("paths.data_dir", " (or GRACE_DATA_DIR)"), ("paths.output_dir", ""))
"""The folders a run writes: config key, and what else sets it."""


def check_folder(path: Path, key: str, also: str = "") -> None:
    """A UserError if `path` (the folder of config key `key`, also set by `also`) cannot be
    created or written: it is a file, lies under a file, or its nearest existing folder refuses
    a new file (grace/data/folders.py; writes nothing)."""
    path = Path(path).absolute()
    fix = f"fix: set {key}{also} to"
    found = obstacle(path)
    if found is None:
        return
    if found.is_file and found.path == path:
        raise UserError(f"{key}={path} is a file, not a folder; {fix} a folder")
    if found.is_file:
        raise UserError(f"{key}={path} lies under the file {found.path}; {fix} a folder elsewhere")
    raise UserError(
        f"{key}={path}: the folder {found.path} is not writable ({found.reason}); "
        f"{fix} a writable folder, or make {found.path} writable"
    )


def check_paths(cfg: DictConfig) -> None:
    """The data folder and the run folder (when it is known before Hydra makes it: set with
    paths.output_dir) can be made and written."""
    for key, also in FOLDERS:
        value = OmegaConf.select(cfg, key, throw_on_resolution_failure=False)
        if value is not None:
            check_folder(Path(str(value)), key, also)
