"""A data cache a run cannot repair, through the real entry point: `python -m grace
task=generate scale=smoke` with GRACE_DATA_DIR in tmp_path refuses it in one line with the fix,
exit code 2, nothing written and no torch loaded (the preflight checks the cache's files before
the run starts; grace/data/store.py, `survey`). One row per kind: a folder where a file belongs,
a file where a folder belongs, a folder that refuses new files, a damaged raw import cache. What
a run can repair (damaged chunks, claims left by stopped runs) is repaired: tests/data/."""

import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
from hydra.utils import instantiate
from test_preflight import HEAVY, files, grace

from grace.data.raw_format import export_raw

GENERATE = ("task=generate", "scale=smoke")


@pytest.fixture
def smoke_cache(cfg_factory, tmp_path) -> Path:
    """The folder `task=generate scale=smoke` generates into, with GRACE_DATA_DIR=tmp_path/data
    (empty: the rows make what they need in it)."""
    root = instantiate(cfg_factory(*GENERATE).dataset).path
    root.mkdir(parents=True)
    return root


def _data_dir(tmp_path: Path) -> dict[str, str]:
    return {"GRACE_DATA_DIR": str(tmp_path / "data")}


def _refused(tmp_path: Path, *overrides: str, expected: str) -> str:
    """Run the command; check it is refused as promised; return the line."""
    before = files(tmp_path)
    code, lines, modules, _ = grace(tmp_path, *overrides, env=_data_dir(tmp_path))
    assert code == 2, lines
    assert len(lines) == 1 and lines[0].startswith("grace: error: "), lines
    assert re.search(expected, lines[0]), lines[0]
    assert files(tmp_path) == before  # no run folder, no log, nothing in the cache
    assert not modules & set(HEAVY)
    return lines[0]


def test_a_shard_that_is_a_folder(tmp_path, smoke_cache):
    shard = smoke_cache / "A5" / "000000-000008.jsonl.gz"
    shard.mkdir(parents=True)
    _refused(
        tmp_path, *GENERATE,
        expected=rf"^grace: error: {shard} is a folder where a file of the data set belongs; "
        r"fix: move it away or delete it: its chunk is then generated again$",
    )  # fmt: skip


def test_corrupt_that_is_a_file_when_a_damaged_chunk_goes_there(tmp_path, smoke_cache):
    (smoke_cache / "A3").mkdir()
    (smoke_cache / "A3" / "000000-000008.json").write_text('{"shard": {"rec')  # truncated
    (smoke_cache / "corrupt").write_text("not a folder\n")
    _refused(
        tmp_path, *GENERATE,
        expected=rf"^grace: error: {smoke_cache / 'corrupt'} is a file where a folder of the "
        r"data set belongs \(.*/corrupt/A3: .*\); fix: move it away or delete it",
    )  # fmt: skip


def test_a_chunk_folder_that_refuses_the_claim(tmp_path, smoke_cache, lock_folder):
    (smoke_cache / "A5").mkdir()
    lock_folder(smoke_cache / "A5")
    _refused(
        tmp_path, *GENERATE,
        expected=rf"^grace: error: {smoke_cache / 'A5'} is not writable \(.*\), and this run "
        r"writes the chunk's claim, shard and manifest there; fix: make it writable",
    )  # fmt: skip


def test_a_raw_cache_shard_that_is_a_folder(tmp_path, cfg_factory, fake_simulator):
    """task=generate makes no raw data set: the default task reads it before any work."""
    raw = tmp_path / "raw"
    simulator = instantiate(fake_simulator)
    for size in (3, 4):
        sample = simulator.sample(size, np.random.default_rng(size))
        sample.assembly.name, sample.info = f"a{size}", {}
        export_raw(sample, raw / sample.assembly.name)
    source = ("dataset=raw", f"dataset.path={raw}", "dataset.sizes=null")
    instantiate(cfg_factory(*source).dataset).load()  # imported and cached
    (cache,) = (tmp_path / "data").iterdir()
    (cache / "A3.jsonl.gz").unlink()
    (cache / "A3.jsonl.gz").mkdir()
    _refused(
        tmp_path, *source,
        expected=rf"^grace: error: {cache}/A3.jsonl.gz: shard unreadable \(Is a directory\); "
        rf"fix: delete {cache} and rerun",
    )  # fmt: skip


@pytest.mark.slow
def test_following_each_fix_ends_its_error_and_the_run_generates(
    tmp_path, cfg_factory, lock_folder
):
    """Three problems at once, each named in turn; after the three fixes the real command
    generates the data set (two A3 and one A5 assemblies of the real simulator)."""
    sizes = "dataset.sizes={3: 2, 5: 1}"
    root = instantiate(cfg_factory(*GENERATE, sizes).dataset).path
    shard = root / "A5" / "000000-000001.jsonl.gz"
    shard.mkdir(parents=True)
    (root / "A3").mkdir()
    (root / "A3" / "000000-000002.json").write_text("{")
    (root / "corrupt").write_text("not a folder\n")
    unlock = lock_folder(root / "A3")
    fixes = {
        str(shard): lambda: shutil.rmtree(shard),
        str(root / "corrupt"): (root / "corrupt").unlink,
        str(root / "A3"): unlock,
    }
    named = []
    for _ in fixes:
        line = _refused(tmp_path, *GENERATE, sizes, expected=r"fix: ")
        path = next(p for p in fixes if line.startswith(f"grace: error: {p} "))
        named.append(path)
        fixes[path]()
    assert sorted(named) == sorted(fixes)
    start = time.perf_counter()
    code, lines, _, _ = grace(tmp_path, *GENERATE, sizes, env=_data_dir(tmp_path))
    assert code == 0, (lines, time.perf_counter() - start)
    assert (root / "A5" / "000000-000001.json").exists()
    assert list((root / "corrupt" / "A3").iterdir())  # the damaged manifest, set aside
