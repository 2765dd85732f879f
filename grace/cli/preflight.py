"""The command line checked before any work: one line per user error, nothing written.

`python -m grace <overrides>` first composes the config with the light schemas (no torch, no
Lightning: about a second) and runs grace/cli/checks.py on it, then loads the schemas of the
groups the task reads (grace/cli/schemas.py; all but the planner's need torch or Lightning) and,
if the command line sets keys of groups the first compose left untyped, composes it again to
check them typed. Only then does Hydra create the run folder and run the task, so a bad override
or interpolation, a value out of its range (grace/cli/ranges.py), an unusable data or run folder
(grace/cli/values.py), a missing or malformed data folder, a protocol the data set cannot serve
or a kept model or assembly task=plan cannot use (grace/cli/checks.py) stops the run before
anything exists on disk. Sweeps (`-m`) are checked per job instead.

A user error prints as one line on stderr, exit code 2; `HYDRA_FULL_ERROR=1` or `debug=true`
shows the traceback instead.
"""

from __future__ import annotations

import logging
import os
import shlex
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from hydra import compose, initialize_config_dir
from hydra._internal.grammar.utils import escape_special_characters
from hydra._internal.utils import get_args_parser
from hydra.core.global_hydra import GlobalHydra
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.override_parser.types import Override, Quote, QuotedString
from hydra.errors import HydraException
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import InterpolationKeyError, OmegaConfBaseException

from grace import CONF_DIR
from grace.cli.checks import check_config, ignored_options
from grace.cli.schemas import light_schemas, referenced_schemas, register_schemas
from grace.cli.signals import stopped
from grace.cli.values import check_folder, check_ranges
from grace.errors import UserError

EXIT_USER_ERROR = 2
CONFIG_ERRORS = (UserError, HydraException, OmegaConfBaseException)
"""What a user's command line or data can cause; anything else is a bug and keeps its trace."""


def one_line(error: BaseException) -> str:
    """`error` as one line: what is wrong, where (file or config key) and the fix."""
    if isinstance(error, UserError):
        return " ".join(str(error).split())
    causes = [error]
    while causes[-1].__cause__ is not None:
        causes.append(causes[-1].__cause__)
    inner = next((e for e in causes if isinstance(e, OmegaConfBaseException)), causes[-1])
    what = str(inner).strip().splitlines()[0] if str(inner).strip() else type(inner).__name__
    key = getattr(inner, "full_key", None)
    where = f" (config key '{key}')" if key else ""
    context = "; ".join(line.strip() for line in str(error).splitlines() if line.strip())
    if inner is not error and context and context not in what:
        what = f"{context.split(';')[0]}: {what}"
    return (
        f"config error: {what}{where}; fix: correct the override "
        "(`python -m grace --help` lists the groups, `--cfg job` prints the config)"
    )


def debugging(argv: list[str]) -> bool:
    """Whether the user asked for tracebacks: HYDRA_FULL_ERROR=1 or a `debug=true` override."""
    return os.environ.get("HYDRA_FULL_ERROR") == "1" or any(
        a.lstrip("+").lower() in ("debug=true", "debug=1") for a in argv
    )


@contextmanager
def user_errors(debug: bool) -> Iterator[None]:
    """Print a user error as one line on stderr and exit 2 (re-raise it when `debug`); after a
    stop signal, raise the stop instead (grace/cli/signals.py)."""
    try:
        yield
    except CONFIG_ERRORS as error:
        if stopped():  # a stop signal broke the config library's state midway: no user error
            raise KeyboardInterrupt("stopped while composing the config") from error
        if debug:
            raise
        print(f"grace: error: {one_line(error)}", file=sys.stderr)
        sys.exit(EXIT_USER_ERROR)


def run_overrides(argv: list[str]) -> list[str] | None:
    """The overrides of a single run, or None for what preflight leaves to Hydra (a sweep, another
    config tree, or --help, --cfg, --info and the like)."""
    args = get_args_parser().parse_args(argv)
    informative = (args.help, args.hydra_help, args.cfg, args.info, args.shell_completion)
    custom = (args.config_path, args.config_name, args.config_dir, args.experimental_rerun)
    if args.multirun or any(informative) or any(custom):
        return None
    return list(args.overrides)


def _top(override: Override) -> str:
    """The config group or top-level key an override sets."""
    return override.key_or_group.split(".")[0].split("/")[0]


def _sets_keys_in(overrides: list[str], groups: set[str]) -> bool:
    """Whether an override sets a key inside one of `groups`."""
    parsed = OverridesParser.create().parse_overrides(overrides)
    return any(_top(o) in groups and "." in o.key_or_group for o in parsed)


def _compose(overrides: list[str], open_groups: set[str]) -> DictConfig:
    """The config of `overrides`, without Hydra's own keys. A key override inside one of
    `open_groups` (their placeholders hold the YAML's keys only) is forced in (`++`), so that its
    value is checked too; a deletion there is left out."""
    parsed = OverridesParser.create().parse_overrides(overrides)
    kept = []
    for text, override in zip(overrides, parsed, strict=True):
        top = _top(override)
        if top == "hydra":
            continue
        if top in open_groups and "." in override.key_or_group:
            if override.is_delete():
                continue
            text = "++" + text.lstrip("+")
        kept.append(text)
    GlobalHydra.instance().clear()
    try:
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            return compose(config_name="config", overrides=kept)
    finally:
        GlobalHydra.instance().clear()


def check_overrides(cfg: DictConfig, overrides: list[str]) -> None:
    """Each override's value resolves (an interpolation names a key that exists), and a run
    folder given with hydra.run.dir can be made."""
    for override in OverridesParser.create().parse_overrides(overrides):
        key = override.key_or_group
        if override.is_delete() or "/" in key:
            continue
        if key == "hydra.run.dir":
            folder = str(override.value()).split("${")[0]  # the part Hydra does not fill in
            check_folder(Path(folder or "."), key)
        elif not key.startswith("hydra."):
            try:
                OmegaConf.select(cfg, key)
            except InterpolationKeyError as error:
                reason = str(error).splitlines()[0]
                raise UserError(
                    f"{override.input_line}: {reason}; fix: name an existing key inside ${{...}} "
                    "(`python -m grace --cfg job` prints them), or give the value itself"
                ) from None
            except OmegaConfBaseException:
                pass  # a resolver that only a run can answer (${hydra:...})


def preflight(argv: list[str]) -> None:
    """Check the command line `argv` in full before Hydra runs it (see the module docstring)."""
    overrides = run_overrides(argv)
    if overrides is None:
        register_schemas()
        return
    register_schemas(light=True)
    light = {path.split("/")[0] for path in light_schemas()}
    placeholders = {path.split("/")[1] for path in referenced_schemas()}
    open_groups = placeholders - light - {"simulator"}
    cfg = _compose(overrides, open_groups)
    for warning in ignored_options(cfg, overrides):
        print(f"grace: warning: {warning}", file=sys.stderr)
    check_overrides(cfg, overrides)
    with _quiet_logs():
        check_config(cfg)  # before the heavy imports
    register_schemas(run=cfg.task.run._target_)  # the schemas the task reads
    if _sets_keys_in(overrides, open_groups):
        check_ranges(_compose(overrides, set()))  # those keys typed, by the groups' schemas


@contextmanager
def _quiet_logs() -> Iterator[None]:
    """No log records below errors while the checks run: logging is not set up yet (Python would
    print them bare), and the run, which checks again, logs them to its terminal and log file."""
    logging.disable(logging.WARNING)
    try:
        yield
    finally:
        logging.disable(logging.NOTSET)


def shell_override(key: str, value: str) -> str:
    """`key=value` as one shell word that Hydra reads back as `value`, whatever it holds
    (spaces, commas, brackets, quotes): to be pasted into a command line."""
    if "'" in value or '"' in value:
        text = QuotedString(text=value, quote=Quote.single).with_quotes()
    else:
        text = escape_special_characters(value)
    return shlex.quote(f"{key}={text}")


def run_dir_overrides(argv: list[str]) -> list[str]:
    """`hydra.run.dir=<dir>` when the user set `paths.output_dir=<dir>` alone, so Hydra's own
    records (.hydra/) land in the run folder rather than in a second, dated one."""
    overrides = run_overrides(argv) or []
    keys = {o.split("=", 1)[0].lstrip("+"): o.split("=", 1)[1] for o in overrides if "=" in o}
    if "paths.output_dir" in keys and "hydra.run.dir" not in keys:
        return [f"hydra.run.dir={keys['paths.output_dir']}"]
    return []
