"""Shard files: gzip-compressed JSON lines, one labelled assembly per line, each checked on read.

The gzip header carries no timestamp or file name (mtime=0, empty name), so the same records
always give the same bytes. Whoever writes a shard keeps its :class:`ShardInfo` (record count and
SHA-256 of the bytes) in a manifest written after it; :func:`read_shard` checks the file against
it, so an empty, short, truncated or altered shard is an error naming the file, never fewer
assemblies served silently (docs/operations.md, "Cache integrity").
"""

from __future__ import annotations

import gzip
import hashlib
import io
import zlib
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from grace.data.atomic import write_bytes_atomic
from grace.data.records import dumps, loads
from grace.domain.sample import LabelledAssembly

SHARD_SUFFIX = ".jsonl.gz"


class ShardError(Exception):
    """A shard that does not hold what its manifest says; the message names the file."""


@dataclass(frozen=True)
class ShardInfo:
    """What a manifest keeps of a shard: its record count and the SHA-256 of its bytes."""

    records: int
    sha256: str

    @classmethod
    def of(cls, data: bytes, records: int) -> ShardInfo:
        return cls(records, hashlib.sha256(data).hexdigest())

    @classmethod
    def from_json(cls, node: Mapping[str, Any]) -> ShardInfo:
        """From a manifest entry; a malformed entry raises KeyError, TypeError or ValueError."""
        records, sha256 = node["records"], node["sha256"]
        if not isinstance(records, int) or not isinstance(sha256, str) or len(sha256) != 64:
            raise ValueError(f"not a shard entry: {dict(node)}")
        return cls(records, sha256)

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def encode_shard(samples: Iterable[LabelledAssembly]) -> bytes:
    """The deterministic bytes of a shard holding `samples` in the given order."""
    buffer = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", fileobj=buffer, compresslevel=6, mtime=0) as f:
        for sample in samples:
            f.write(dumps(sample).encode("utf-8") + b"\n")
    return buffer.getvalue()


def write_shard(path: str | Path, samples: Iterable[LabelledAssembly]) -> ShardInfo:
    """Write the shard atomically; its info goes into the writer's manifest."""
    samples = list(samples)
    data = encode_shard(samples)
    write_bytes_atomic(path, data)
    return ShardInfo.of(data, len(samples))


def check_shard(path: str | Path, expected: ShardInfo) -> bytes:
    """The shard's bytes if they are the ones its manifest describes; else ShardError."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise ShardError(f"{path}: shard missing") from None
    except OSError as e:  # a folder in its place, no permission to read
        raise ShardError(f"{path}: shard unreadable ({e.strerror})") from None
    if hashlib.sha256(data).hexdigest() != expected.sha256:
        raise ShardError(
            f"{path}: shard corrupted ({len(data)} bytes whose SHA-256 is not the one its "
            f"manifest records for its {expected.records} records)"
        )
    return data


def read_shard(path: str | Path, expected: ShardInfo) -> list[LabelledAssembly]:
    """The assemblies of a shard, checked against its manifest's checksum and record count."""
    data = check_shard(path, expected)
    try:
        text = gzip.decompress(data).decode("utf-8")
        samples = [loads(line) for line in text.splitlines() if line.strip()]
    except (OSError, EOFError, zlib.error, UnicodeDecodeError) as e:
        raise ShardError(f"{path}: shard unreadable ({e})") from None
    except (ValueError, KeyError, TypeError, IndexError) as e:  # JSON, or not a record
        raise ShardError(
            f"{path}: shard holds a line that is no record ({type(e).__name__}: {e})"
        ) from None
    if len(samples) != expected.records:
        raise ShardError(f"{path}: shard holds {len(samples)} of its {expected.records} records")
    return samples
