"""Entry point: `python -m grace task=<name> ...` (or `grace ...`) composes the config and runs one
task. The configs ship inside the package (grace/conf), so this works from any folder.

The command line is checked first (grace/cli/preflight.py): a user error is one line on
stderr and exit code 2, before Hydra creates the run folder. Ctrl-C and SIGTERM stop the run
and its worker processes (grace/cli/signals.py); the same command with
`paths.output_dir=<the run folder>` resumes it.
"""

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NoReturn

import hydra
from omegaconf import DictConfig

from grace import CONF_DIR
from grace.cli.preflight import (
    debugging,
    preflight,
    run_dir_overrides,
    shell_override,
    user_errors,
)
from grace.cli.signals import (
    exit_interrupted,
    held_while_loading,
    sigterm_as_interrupt,
    stopped,
)


# An absolute path: found whether this module runs as __main__ or from the console script.
@hydra.main(version_base="1.3", config_path=str(CONF_DIR), config_name="config")
def run(cfg: DictConfig) -> float | None:
    """One Hydra job: the task of `cfg` (a user error: one line, exit 2)."""
    try:
        with held_while_loading():
            from grace.cli.runner import run_task  # torch and Lightning: after the checks

        with user_errors(debugging(sys.argv[1:]) or bool(cfg.debug)):
            return run_task(cfg)
    except Exception:
        if not stopped():  # a bug; else a worker or helper the same signal stopped
            raise
        _interrupted(cfg.paths.output_dir)
    except KeyboardInterrupt:
        _interrupted(cfg.paths.output_dir)


def _interrupted(out: str) -> NoReturn:
    where = shell_override("paths.output_dir", out)
    resume = f"grace: interrupted; to resume: the same command with {where}"
    exit_interrupted(resume, sys.stdout)


def main() -> None:
    """Check the command line, then let Hydra run it."""
    sigterm_as_interrupt()
    before_run = "grace: interrupted before the run started; nothing was written"
    with _stops_early(before_run), user_errors(debugging(sys.argv[1:])):
        preflight(sys.argv[1:])
        sys.argv += run_dir_overrides(sys.argv[1:])
    # While Hydra composes the config or sets up the run folder:
    with _stops_early("grace: interrupted before the task started"):
        run()


@contextmanager
def _stops_early(message: str) -> Iterator[None]:
    """A stop before any worker or file exists: `message` and exit 130. As in :func:`run`, an
    error raised after a stop signal is that stop (the signal broke what was running)."""
    try:
        yield
    except Exception:
        if not stopped():
            raise
        exit_interrupted(message, sys.stderr)
    except KeyboardInterrupt:
        exit_interrupted(message, sys.stderr)


if __name__ == "__main__":
    main()
