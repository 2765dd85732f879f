"""Who writes where: our messages and progress on the terminal, everything in the run's log.

Hydra's job logging sends our loggers to the terminal and to `paths.log_file`. Lightning's
messages (accelerator banners, hints, advertising tips) and Python warnings (third-party
deprecations) go to `paths.log_file` only. A fold trained in a worker process writes all of its
messages there too, tagged with the fold: the parent process shows its progress (progress.py).
"""

from __future__ import annotations

import logging
from pathlib import Path

FORMAT = "[%(asctime)s][%(name)s][%(levelname)s] - %(message)s"
"""Hydra's default job-log format."""

THIRD_PARTY = ("lightning", "lightning.pytorch", "lightning.fabric", "pytorch_lightning")
"""Loggers whose messages are for the log file, not the terminal."""


class FolderFileHandler(logging.FileHandler):
    """A FileHandler that creates its file's folder: Hydra's job log is `paths.log_file`, which
    lies in `paths.output_dir`, a folder Hydra does not create when the user sets it."""

    def __init__(self, filename: str | Path, *args: object, **kwargs: object) -> None:
        Path(filename).parent.mkdir(parents=True, exist_ok=True)
        super().__init__(filename, *args, **kwargs)


def _file_handler(log_file: str | Path, fmt: str) -> logging.Handler:
    Path(log_file).parent.mkdir(parents=True, exist_ok=True)
    handler = logging.FileHandler(log_file)
    handler.setFormatter(logging.Formatter(fmt))
    return handler


def quiet_terminal(log_file: str | Path) -> None:
    """In the main process: Lightning's messages and all warnings to `log_file` only."""
    logging.captureWarnings(True)
    handler = _file_handler(log_file, FORMAT)
    for name in (*THIRD_PARTY, "py.warnings"):
        logger = logging.getLogger(name)
        logger.handlers = [handler]
        logger.propagate = False


def log_to_file(log_file: str | Path, tag: str) -> None:
    """In a worker process: every message and warning to `log_file` only, tagged with `tag`."""
    logging.captureWarnings(True)
    root = logging.getLogger()
    root.handlers = [_file_handler(log_file, FORMAT.replace("[%(name)s]", f"[{tag}][%(name)s]"))]
    root.setLevel(logging.INFO)
    for name in (*THIRD_PARTY, "py.warnings"):
        logger = logging.getLogger(name)
        logger.handlers = []
        logger.propagate = True
