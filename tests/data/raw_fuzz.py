"""Fuzzed raw folders (docs/raw-format.md) and what the importer makes of each.

A fuzzed folder is a copy of a valid one with one to three mutations of its files: bytes flipped,
a byte range or a line deleted, a line duplicated, numbers (anywhere, or a part's position)
replaced by huge, tiny, infinite, not-a-number or malformed ones, bytes that are not UTF-8
inserted, a file truncated, emptied or deleted. The
importer must import it or refuse it in one line naming the file and the fix; anything else (an
exception of another kind, a message of several lines) is a traceback for the user, and an
import that takes longer than :data:`HANG_SECONDS` is a hang.
"""

from __future__ import annotations

import re
import shutil
import signal
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from grace.data.raw_format import (
    ASSEMBLY_FILE,
    RAW_FILES,
    RawFormatError,
    import_raw,
    read_assembly,
)

HANG_SECONDS = 10.0
NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:e-?\d+)?")
ODD_NUMBERS = (
    *(b"1.7e308", b"-1.7e308", b"1e300", b"-1e300", b"1e20", b"-3.4e38", b"9" * 400),
    *(b"1e309", b"-1e309", b"nan", b"inf", b"-inf", b"1e-320", b"-0"),
    *(b"0x10", b"1_000", b"2001", b"-2000.5", b"5658"),
)
NOT_UTF8 = (b"\xff", b"\xc3\x28", b"\xed\xa0\x80", b"\xfe\xff", b"\x80abc")


class Hang(Exception):
    """The import ran longer than HANG_SECONDS."""


def _flip(data: bytes, rng: np.random.Generator) -> bytes:
    if not data:
        return data
    out = bytearray(data)
    for i in rng.integers(0, len(out), size=int(rng.integers(1, 4))):
        out[i] ^= 1 << int(rng.integers(0, 8))
    return bytes(out)


def _delete(data: bytes, rng: np.random.Generator) -> bytes:
    lines = data.splitlines(keepends=True)
    if lines and rng.random() < 0.5:
        del lines[int(rng.integers(0, len(lines)))]
        return b"".join(lines)
    start = int(rng.integers(0, len(data) + 1))
    return data[:start] + data[start + int(rng.integers(1, 20)) :]


def _duplicate(data: bytes, rng: np.random.Generator) -> bytes:
    lines = data.splitlines(keepends=True)
    if not lines:
        return data + data
    i = int(rng.integers(0, len(lines)))
    return b"".join(lines[: i + 1] + lines[i : i + int(rng.integers(1, 3))] + lines[i + 1 :])


def _odd_number(data: bytes, rng: np.random.Generator) -> bytes:
    """One to three numbers replaced by huge, tiny, infinite, not-a-number or malformed ones."""
    for _ in range(int(rng.integers(1, 4))):
        numbers = list(NUMBER.finditer(data))
        odd = ODD_NUMBERS[int(rng.integers(0, len(ODD_NUMBERS)))]
        if not numbers:
            return data + odd
        match = numbers[int(rng.integers(0, len(numbers)))]
        data = data[: match.start()] + odd + data[match.end() :]
    return data


def _odd_coordinate(data: bytes, rng: np.random.Generator) -> bytes:
    """One to three x or y positions (4th or 8th pose entry) of the part lines of assembly.spec
    replaced by odd numbers."""
    lines = data.splitlines(keepends=True)
    parts = [i for i, line in enumerate(lines) if line.count(b";") == 12 and line.count(b" ") == 2]
    if not parts:
        return _odd_number(data, rng)
    for _ in range(int(rng.integers(1, 4))):
        i = parts[int(rng.integers(0, len(parts)))]
        name, kind, pose = lines[i].rstrip(b"\r\n").split(b" ")
        cells = pose.replace(b"&", b";").split(b";")
        cells[3 if rng.random() < 0.5 else 7] = ODD_NUMBERS[int(rng.integers(0, len(ODD_NUMBERS)))]
        rows = [b";".join(cells[r * 4 : r * 4 + 4]) for r in range(4)]
        lines[i] = b" ".join([name, kind, b"&".join(rows)]) + b"\n"
    return b"".join(lines)


def _not_utf8(data: bytes, rng: np.random.Generator) -> bytes:
    at = int(rng.integers(0, len(data) + 1))
    return data[:at] + NOT_UTF8[int(rng.integers(0, len(NOT_UTF8)))] + data[at:]


def _truncate(data: bytes, rng: np.random.Generator) -> bytes:
    return data[: int(rng.integers(0, len(data) + 1))]


MUTATIONS: dict[str, Callable[[bytes, np.random.Generator], bytes]] = {
    "flip": _flip,
    "delete": _delete,
    "duplicate": _duplicate,
    "odd number": _odd_number,
    "odd coordinate": _odd_coordinate,
    "not utf-8": _not_utf8,
    "truncate": _truncate,
    "empty": lambda data, rng: b"",
}


def fuzz_folder(base: Path, out: Path, rng: np.random.Generator) -> list[str]:
    """Copy the raw folder `base` to `out` and mutate it; returns what was done."""
    shutil.copytree(base, out)
    done = []
    for _ in range(int(rng.integers(1, 4))):
        name = list(MUTATIONS)[int(rng.integers(0, len(MUTATIONS)))]
        file = out / RAW_FILES[int(rng.integers(0, len(RAW_FILES)))]
        if name == "odd coordinate":
            file = out / ASSEMBLY_FILE
        elif rng.random() < 0.05:
            file.unlink(missing_ok=True)
            done.append(f"{file.name}: deleted")
            continue
        data = file.read_bytes() if file.exists() else b""
        file.write_bytes(MUTATIONS[name](data, rng))
        done.append(f"{file.name}: {name}")
    return done


def _alarm(signum, frame) -> None:
    raise Hang


def outcome(folder: Path) -> str:
    """`imported`, `one line` (a RawFormatError of one line naming a file of the folder and the
    fix), `traceback: <what>` or `hang`: the importer and task=plan's reader on `folder`."""
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, HANG_SECONDS)
    try:
        import_raw(folder)
        read_assembly(folder)
        return "imported"
    except RawFormatError as e:
        text = str(e)
        if "\n" in text or not text.startswith(str(folder)) or "; fix: " not in text:
            return f"traceback: a message that is not one line naming the file and fix: {text!r}"
        return "one line"
    except Hang:
        return "hang"
    except Exception as e:  # what the user would see as a traceback
        return f"traceback: {type(e).__name__}: {e}"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def fuzz_counts(bases: Sequence[Path], out: Path, count: int, seed: int) -> tuple[Counter, dict]:
    """Outcomes of `count` fuzzed copies of the `bases`, and the mutations of each bad one."""
    rng = np.random.default_rng(seed)
    counts: Counter = Counter()
    bad = {}
    for i in range(count):
        folder = out / f"fuzz_{i:03d}"
        done = fuzz_folder(bases[i % len(bases)], folder, rng)
        result = outcome(folder)
        counts[result.split(":")[0]] += 1
        if result.startswith(("traceback", "hang")):
            bad[folder.name] = (done, result)
    return counts, bad
