"""SIGTERM stops a run the way Ctrl-C does, so every worker process is stopped too.

Python's default SIGTERM ends the main process on the spot: joblib's fold workers and the data
generation pool live on. As a KeyboardInterrupt it unwinds instead: joblib aborts and kills its
workers, the generation pool terminates its own, and every file is written atomically, so the
run leaves complete files only, from which a rerun resumes (grace/model/resume.py).
"""

from __future__ import annotations

import signal
from types import FrameType

EXIT_INTERRUPTED = 130
"""The shell's code for a run stopped by a signal (128 + SIGINT)."""


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")


def sigterm_as_interrupt() -> None:
    """From now on SIGTERM raises KeyboardInterrupt in the main thread, as SIGINT does."""
    signal.signal(signal.SIGTERM, _interrupt)
