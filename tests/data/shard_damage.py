"""Damage a shard file as a crash, a full disk or a bad copy would: shared by the tests of a
single shard (test_shards.py) and of the data store that finds, sets aside and regenerates
damaged chunks (test_store.py)."""

from collections.abc import Sequence
from pathlib import Path

from grace.data.shards import encode_shard
from grace.domain.sample import LabelledAssembly

SHARD_DAMAGE = ("empty", "half", "flipped", "fewer records")


def damage_shard(path: Path, how: str, records: Sequence[LabelledAssembly]) -> None:
    """Damage the shard at `path` by `how` (SHARD_DAMAGE); `records` are its intact records, of
    which "fewer records" writes all but the last as a valid gzip."""
    data = path.read_bytes()
    if how == "empty":
        path.write_bytes(b"")
    elif how == "half":
        path.write_bytes(data[: len(data) // 2])
    elif how == "flipped":
        path.write_bytes(data[:40] + bytes(b ^ 0xFF for b in data[40:48]) + data[48:])
    elif how == "fewer records":
        path.write_bytes(encode_shard(records[:-1]))
    else:
        raise ValueError(f"unknown damage {how!r}")
