"""Checks of single values in a composed config: numbers within their ranges, folders usable.

Run by the preflight (grace/cli/preflight.py) before the run folder exists, so a seed of -1, a
λ of 1.5 or a data folder that is a file stops the command in one line naming the key and the
fix, with nothing written; the same checks run again inside the run (grace/cli/runner.py).
The ranges themselves: grace/cli/ranges.py; docs/operations.md, "Bad input".
"""

from __future__ import annotations

from pathlib import Path

from omegaconf import DictConfig, ListConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from grace.cli.ranges import RANGES, number
from grace.data.folders import obstacle
from grace.errors import UserError


def _numbers(value: object) -> list[float] | None:
    """The numbers of `value` to check: a number, or each number of a list; None for anything
    else (a string the typed compose refuses, null, a mapping, an unresolvable list)."""
    if isinstance(value, ListConfig):
        try:
            value = OmegaConf.to_container(value, resolve=True)
        except OmegaConfBaseException:
            return None
    items = value if isinstance(value, list) else [value]
    numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in items)
    return items if items and numeric else None


def check_ranges(cfg: DictConfig) -> None:
    """A UserError naming the first key of RANGES (grace/cli/ranges.py) whose value lies
    outside its range; keys absent from `cfg`, null or not yet resolvable pass."""
    for key, bound in RANGES.items():
        value = OmegaConf.select(cfg, key, throw_on_resolution_failure=False)
        items = _numbers(value)
        bad = [v for v in items or () if not bound.holds(v)]
        if not bad:
            continue
        if isinstance(value, ListConfig):
            kept = [number(v) for v in items if bound.holds(v)] or [number(bound.suggestion())]
            what, fix = f"{key}={items}: {bad[0]} is", f"[{','.join(kept)}]"
        else:
            what, fix = f"{key}={value} is", number(bound.suggestion())
        raise UserError(f"{what} outside {bound.interval()}; fix: {key}={fix} ({bound.why})")


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
