"""Shard files: gzip-compressed JSON lines, one labelled assembly per line.

The gzip header carries no timestamp or file name (mtime=0, empty name), so the same records
always give the same bytes.
"""

from __future__ import annotations

import gzip
import io
from collections.abc import Iterable
from pathlib import Path

from grace.data.atomic import write_bytes_atomic
from grace.data.records import dumps, loads
from grace.domain.sample import LabelledAssembly

SHARD_SUFFIX = ".jsonl.gz"


def encode_shard(samples: Iterable[LabelledAssembly]) -> bytes:
    """The deterministic bytes of a shard holding `samples` in the given order."""
    buffer = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", fileobj=buffer, compresslevel=6, mtime=0) as f:
        for sample in samples:
            f.write(dumps(sample).encode("utf-8") + b"\n")
    return buffer.getvalue()


def write_shard(path: str | Path, samples: Iterable[LabelledAssembly]) -> None:
    write_bytes_atomic(path, encode_shard(samples))


def read_shard(path: str | Path) -> list[LabelledAssembly]:
    with gzip.open(path, "rt", encoding="utf-8") as f:
        return [loads(line) for line in f if line.strip()]
