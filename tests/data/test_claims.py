import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from grace.data import claims


def _write(path: Path, text: str, idle: float = 0.0) -> Path:
    """A claim file holding `text`, last touched `idle` seconds ago."""
    path.write_text(text)
    os.utime(path, (time.time() - idle,) * 2)
    return path


def _owner(pid: int, host: str | None = None) -> str:
    return json.dumps({"host": host or socket.gethostname(), "pid": pid})


def _dead_pid() -> int:
    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    return int(done.stdout)


CASES = {
    # what the claim holds, seconds since it was touched, taken over?
    "empty, left by a stopped run": ("", 60.0, True),
    "empty, just made": ("", 0.0, False),
    "garbage, left by a stopped run": ("{not json", 60.0, True),
    "a dead pid of this host": (lambda: _owner(_dead_pid()), 0.0, True),
    "this very process's pid (a rerun given its pid)": (lambda: _owner(os.getpid()), 0.0, True),
    "a live pid of this host": (lambda: _owner(1), 0.0, False),
    "a live pid of this host, untouched 11 min": (lambda: _owner(1), 660.0, True),
    "another host's, just touched": (lambda: _owner(1, "elsewhere"), 0.0, False),
    "another host's, untouched 11 min": (lambda: _owner(1, "elsewhere"), 660.0, True),
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_a_claim_no_live_owner_holds_is_taken_over(tmp_path, case):
    text, idle, stale = CASES[case]
    text = text() if callable(text) else text
    path = _write(tmp_path / "c.claim", text, idle)
    assert (claims.live_holder(path) is None) == stale
    assert claims.claim(path) == stale
    assert path.read_text() == (_owner(os.getpid()) if stale else text)
    assert [p.name for p in tmp_path.iterdir()] == ["c.claim"]  # no renamed leftovers


def test_the_wait_for_a_claim_is_named_with_when_it_ends(tmp_path):
    empty = claims.holder(_write(tmp_path / "a.claim", ""))
    assert str(empty) == "names no owner (empty); taken over once 2 s old"
    local = claims.holder(_write(tmp_path / "b.claim", _owner(1), idle=30.0))
    assert str(local) == (
        "held by pid 1 on this host; taken over if that process ends or it stays untouched for "
        "10 min (untouched for 30 s now)"
    )
    remote = claims.holder(_write(tmp_path / "c.claim", _owner(7, "elsewhere")))
    assert str(remote).startswith(
        "held by pid 7 on host elsewhere; taken over if it stays untouched for 10 min"
    )
    assert claims.holder(tmp_path / "gone.claim") is None
