import gzip
import struct
import time

import numpy as np
from hydra.utils import instantiate

from grace.data.records import dumps
from grace.data.shards import read_shard, write_shard


def _samples(fake_simulator):
    simulator = instantiate(fake_simulator)
    return [simulator.sample(n, np.random.default_rng(n)) for n in (3, 4, 5)]


def test_shard_bytes_do_not_depend_on_the_clock(tmp_path, fake_simulator, monkeypatch):
    """Same records, written a day apart: the same bytes (gzip would stamp the time otherwise)."""
    samples = _samples(fake_simulator)
    monkeypatch.setattr(time, "time", lambda: 1_700_000_000.0)
    write_shard(tmp_path / "a.jsonl.gz", samples)
    monkeypatch.setattr(time, "time", lambda: 1_700_086_400.0)
    write_shard(tmp_path / "b.jsonl.gz", samples)
    data = (tmp_path / "a.jsonl.gz").read_bytes()
    assert (tmp_path / "b.jsonl.gz").read_bytes() == data
    # RFC 1952 header: magic, deflate, no flags (so no file name), MTIME = 0.
    magic, method, flags, mtime = struct.unpack("<HBBI", data[:8])
    assert (magic, method, flags, mtime) == (0x8B1F, 8, 0, 0)
    lines = gzip.decompress(data).decode("utf-8").splitlines()
    assert lines == [dumps(s) for s in samples]


def test_shard_round_trip(tmp_path, fake_simulator):
    samples = _samples(fake_simulator)
    for sample in samples:
        sample.info.pop("seconds")  # volatile: kept out of the records
    write_shard(tmp_path / "s.jsonl.gz", samples)
    assert read_shard(tmp_path / "s.jsonl.gz") == samples
