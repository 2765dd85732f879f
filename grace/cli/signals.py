"""SIGTERM stops a run the way Ctrl-C does, so every worker process is stopped too.

Python's default SIGTERM ends the main process on the spot: joblib's fold workers and the data
generation pool live on. As a KeyboardInterrupt it unwinds instead: joblib aborts and kills its
workers, the generation pool terminates its own, and every file is written atomically, so the
run leaves complete files only, from which a rerun resumes (grace/model/resume.py).

A signal to the whole process group (`timeout`, `scancel`, `kill -- -<pgid>`, Ctrl-C) reaches
the helpers too: fold workers die at once on SIGTERM and leave SIGINT to the main process
(:func:`as_worker`), the progress display's queue server ignores both until the main process
shuts it down (:func:`ignore_stops`), and whatever a dying worker makes the main process raise
is read as the stop it is (:func:`stopped`), so the run ends with one line either way.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import NoReturn, TextIO

EXIT_INTERRUPTED = 130
"""The shell's code for a run stopped by a signal (128 + SIGINT)."""

_received: list[str] = []


def _interrupt(signum: int, frame: FrameType | None) -> None:
    _received.append(signal.Signals(signum).name)
    raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")


def sigterm_as_interrupt() -> None:
    """From now on SIGTERM raises KeyboardInterrupt in the main thread, as SIGINT does, and
    either is remembered (:func:`stopped`)."""
    signal.signal(signal.SIGTERM, _interrupt)
    signal.signal(signal.SIGINT, _interrupt)


@contextmanager
def held_while_loading() -> Iterator[None]:
    """Hold SIGINT and SIGTERM while heavy libraries import, then take them.

    A KeyboardInterrupt raised inside a C extension's initialisation surfaces as an ImportError
    ("initialization failed"), or is swallowed by the extension (mujoco's imports a submodule
    from C and ignores the failure: the run then went on to its end, exit 0). So while the block
    runs, a stop is only noted, and it is raised when the block ends, between two imports, as a
    clean stop. Blocking the signals instead (pthread_sigmask) blocks them in this thread only:
    the kernel then hands them to another thread (torch's, once it is imported) and CPython
    still runs the handler here.
    """
    stops = (signal.SIGINT, signal.SIGTERM)
    held: list[int] = []
    before = {stop: signal.getsignal(stop) for stop in stops}
    for stop in stops:
        signal.signal(stop, lambda signum, frame: held.append(signum))
    try:
        yield
    finally:
        for stop, handler in before.items():
            signal.signal(stop, handler)
        for signum in held[:1]:  # one stop is enough
            signal.raise_signal(signum)


def exit_interrupted(message: str, stream: TextIO) -> NoReturn:
    """Print `message` and end the process with exit code 130.

    A KeyboardInterrupt that leaves code run from source text (`eval`/`exec`: every namedtuple
    and dataclass an import defines) is marked unhandled in CPython, which then ends the process
    by SIGINT at exit whatever code `sys.exit` gave (Python/pythonrun.c `run_eval_code_obj`,
    Modules/main.c `Py_RunMain`), even after this process caught it. Running source text once
    more clears that mark: Python has no other way to say the interrupt was handled.
    """
    print(message, file=stream)
    exec("")  # clears CPython's unhandled-interrupt mark (see above)
    sys.exit(EXIT_INTERRUPTED)


def stopped() -> bool:
    """Whether this process received SIGTERM or SIGINT."""
    return bool(_received)


def as_worker() -> None:
    """In a worker process: SIGTERM ends it at once, silently; SIGINT is left to the main
    process, which stops its workers."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def ignore_stops() -> None:
    """In a helper process the main process shuts down itself (the progress queue's server)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
