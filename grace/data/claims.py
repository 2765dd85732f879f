"""Claim files: one process at a time works on a chunk, however many generate the same data set.

A claim is a file created with O_EXCL beside the chunk, holding the owner's host and pid. A
second process finds it and turns to another chunk, so two runs generating one data set at once
share the work instead of doing it twice. A claim whose owner died (a dead pid on this host, or
on another host a claim not touched for :data:`STALE_SECONDS`: the owner touches it after every
assembly) is taken over: renamed away first, so that of several processes finding it stale one
only takes it. Written by hand: filelock's locks are released when their process dies, but they
cannot say who holds one and an NFS mount may not honour them; an O_EXCL file works on any file
system that a shared data cache lives on.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
from pathlib import Path

STALE_SECONDS = 600.0
"""A claim from another host untouched this long is taken over (its owner touches it after every
assembly it generates, seconds apart)."""


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


def _stale(path: Path) -> bool:
    """Whether the claim at `path` belongs to nobody alive (False if it vanished meanwhile)."""
    try:
        text = path.read_text()
        age = time.time() - path.stat().st_mtime
    except FileNotFoundError:
        return False
    try:
        owner = json.loads(text)
        host, pid = owner["host"], int(owner["pid"])
    except (ValueError, KeyError, TypeError):  # being written, or garbage
        return age > STALE_SECONDS
    if host == socket.gethostname():
        return not _alive(pid)
    return age > STALE_SECONDS


def claim(path: Path) -> bool:
    """Take the claim at `path` for this process: True if it is ours now, False if a live
    process holds it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    for _ in range(2):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            if not _stale(path):
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
    """Tell other hosts this claim's owner still works on it."""
    with contextlib.suppress(FileNotFoundError):
        os.utime(path)


def release(path: Path) -> None:
    """Drop the claim at `path` if it is still this process's own."""
    try:
        if json.loads(path.read_text()) == _owner():
            path.unlink()
    except (FileNotFoundError, ValueError):
        pass


def holder_alive(path: Path) -> bool:
    """Whether a live process holds the claim at `path`."""
    return path.exists() and not _stale(path)
