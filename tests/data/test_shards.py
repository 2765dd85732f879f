import gzip
import struct
import time

import numpy as np
import pytest
from hydra.utils import instantiate
from shard_damage import SHARD_DAMAGE, damage_shard

from grace.data.records import dumps
from grace.data.shards import ShardError, ShardInfo, read_shard, write_shard


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
    info = write_shard(tmp_path / "s.jsonl.gz", samples)
    assert info.records == 3
    assert read_shard(tmp_path / "s.jsonl.gz", info) == samples


@pytest.mark.parametrize("how", SHARD_DAMAGE)
def test_a_damaged_shard_is_an_error_naming_it(tmp_path, fake_simulator, how):
    samples = _samples(fake_simulator)
    path = tmp_path / "s.jsonl.gz"
    info = write_shard(path, samples)
    damage_shard(path, how, samples)
    with pytest.raises(ShardError, match=rf"^{path}: shard corrupted"):
        read_shard(path, info)


def test_a_shard_short_of_its_count_is_an_error_even_with_its_checksum(tmp_path, fake_simulator):
    samples = _samples(fake_simulator)
    path = tmp_path / "s.jsonl.gz"
    info = write_shard(path, samples[:2])
    with pytest.raises(ShardError, match="holds 2 of its 3 records"):
        read_shard(path, ShardInfo(3, info.sha256))
