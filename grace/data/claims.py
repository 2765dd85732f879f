"""Claim files: one process at a time works on a chunk, however many generate the same data set.

A claim is a file created with O_EXCL beside the chunk, holding the owner's host and pid. A
second process finds it and turns to another chunk, so two runs generating one data set at once
share the work instead of doing it twice. A claim that no live owner holds is taken over: renamed
away first, so that of several processes finding it stale one only takes it. No live owner holds
a claim when

- it names a pid of this host that no longer runs, or this very process (a run stopped before
  it released the claim, and a rerun given the same pid, as a container's first process is);
- it names no owner (empty, or not the JSON of one) and is :data:`WRITE_SECONDS` old: its
  owner writes it right after creating it, so it was left by a process stopped in between, or
  made by hand;
- it has not been touched for :data:`STALE_SECONDS` (its owner touches it after every assembly),
  the only sign when the owner is another host's process, and the end of a wait for a pid of
  this host that has been reused.

Taking a claim over wrongly costs work, never data: both processes then generate the chunk, to
the same bytes, each written atomically. Written by hand: filelock's locks are released when their
process dies, but they cannot say who holds one and an NFS mount may not honour them; an O_EXCL
file works on any file system that a shared data cache lives on.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
from dataclasses import dataclass
from pathlib import Path

STALE_SECONDS = 600.0
"""A claim untouched this long is taken over (its owner touches it after every assembly it
generates, seconds apart)."""

WRITE_SECONDS = 2.0
"""A claim naming no owner is taken over once this old (its owner writes it microseconds after
creating it)."""


def _owner() -> dict[str, object]:
    return {"host": socket.gethostname(), "pid": os.getpid()}


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


@dataclass(frozen=True)
class Holder:
    """What a claim file says: its owner's host and pid (None if it names none) and how long
    ago it was last touched."""

    host: str | None
    pid: int | None
    idle: float

    @property
    def local(self) -> bool:
        return self.host == socket.gethostname()

    def stale(self) -> bool:
        """Whether no live process holds the claim (see the module docstring)."""
        if self.pid is None:
            return self.idle >= WRITE_SECONDS
        if self.local and (self.pid == os.getpid() or not _alive(self.pid)):
            return True
        return self.idle > STALE_SECONDS

    def __str__(self) -> str:
        """Who holds the claim and when it is taken over, for the line a waiting run logs."""
        if self.pid is None:
            return f"names no owner (empty); taken over once {WRITE_SECONDS:g} s old"
        where = "this host" if self.local else f"host {self.host}"
        ends = "that process ends or " if self.local else ""
        return (
            f"held by pid {self.pid} on {where}; taken over if {ends}it stays untouched for "
            f"{STALE_SECONDS / 60:g} min (untouched for {self.idle:.0f} s now)"
        )


def holder(path: Path) -> Holder | None:
    """Who holds the claim at `path`, or None if there is none (or it vanished meanwhile)."""
    try:
        idle = time.time() - path.stat().st_mtime
    except FileNotFoundError:
        return None
    try:
        owner = json.loads(path.read_text())
        return Holder(str(owner["host"]), int(owner["pid"]), idle)
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, TypeError):  # being written, garbage, unreadable
        return Holder(None, None, idle)


def claim(path: Path) -> bool:
    """Take the claim at `path` for this process: True if it is ours now, False if a live
    process holds it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    for _ in range(2):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            found = holder(path)
            if found is None or not found.stale():
                return False
            try:  # only one of the processes that found it stale wins the rename
                os.replace(path, path.with_name(f"{path.name}.stale.{os.getpid()}"))
            except FileNotFoundError:
                return False
            path.with_name(f"{path.name}.stale.{os.getpid()}").unlink(missing_ok=True)
            continue
        with os.fdopen(fd, "w") as f:
            json.dump(_owner(), f)
        return True
    return False


def touch(path: Path) -> None:
    """Tell other processes this claim's owner still works on it."""
    with contextlib.suppress(FileNotFoundError):
        os.utime(path)


def release(path: Path) -> None:
    """Drop the claim at `path` if it is still this process's own."""
    try:
        if json.loads(path.read_text()) == _owner():
            path.unlink()
    except (FileNotFoundError, ValueError):
        pass


def live_holder(path: Path) -> Holder | None:
    """The live process holding the claim at `path`, or None if none does."""
    found = holder(path)
    return None if found is None or found.stale() else found
