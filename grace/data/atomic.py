"""Atomic file writes: a reader never sees a half-written file."""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, BinaryIO


def _read_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _read_umask()


@contextmanager
def replacing(path: str | Path) -> Iterator[BinaryIO]:
    """A binary file to write `path` through: a temporary file beside it, renamed over `path`
    when the block ends without error (removed otherwise)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            yield f
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; give what open() would
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write `data` to a temporary file beside `path`, then rename it over `path`."""
    with replacing(path) as f:
        f.write(data)


def write_text_atomic(path: str | Path, text: str) -> None:
    write_bytes_atomic(path, text.encode("utf-8"))


def write_lines_atomic(path: str | Path, lines: Iterable[str]) -> None:
    """Write `lines` (each ending in a newline) as they come, atomically: memory stays flat
    however many there are."""
    with replacing(path) as f:
        f.writelines(line.encode("utf-8") for line in lines)


def finite_or_null(obj: Any) -> Any:
    """`obj` with every non-finite float (NaN, ±Infinity) replaced by None, tuples as lists."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {key: finite_or_null(value) for key, value in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite_or_null(value) for value in obj]
    return obj


def strict_json(obj: Any, indent: int | None = 2) -> str:
    """`obj` as strict JSON text (RFC 8259), which every parser reads: Python would write NaN and
    Infinity, which strict parsers reject. A non-finite number becomes null: in every JSON file
    grace writes, null in a number's place means undefined (NaN: an AUC without a positive
    label) or unbounded (±∞: no complete sequence was scored); docs/operations.md."""
    return json.dumps(finite_or_null(obj), indent=indent, allow_nan=False)


def write_json_atomic(path: str | Path, obj: Any, indent: int | None = 2) -> None:
    """Write `obj` atomically as strict JSON (:func:`strict_json`), ending with a newline."""
    write_text_atomic(path, strict_json(obj, indent) + "\n")
