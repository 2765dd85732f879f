import gzip
import hashlib
import importlib
import json
import logging
import multiprocessing as mp
import os
import re
import shutil
import socket
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from hydra.utils import instantiate
from omegaconf import open_dict
from shard_damage import SHARD_DAMAGE, damage_shard

from grace.data import claims
from grace.data.records import dumps, loads
from grace.data.shards import SHARD_SUFFIX, ShardInfo, encode_shard
from grace.data.store import Chunk, plan, read_chunk, seconds_per_assembly
from grace.domain.canonical import assembly_key
from grace.errors import UserError


def generate(cfg):
    return instantiate(cfg.dataset).generate()


def load_generated(cfg):
    return instantiate(cfg.dataset).load()


def dataset_dir(cfg):
    return instantiate(cfg.dataset).path


@pytest.fixture
def fake_cfg(cfg_factory, fake_simulator):
    """A generated-dataset config on the fake simulator; groups the data layer ignores dropped."""

    def make(*overrides: str, sizes: str = "{3: 5, 4: 4, 6: 3}"):
        # `dataset.sizes={...}` replaces the preset's mapping; a second such override would merge.
        cfg = cfg_factory(
            "task=generate", "~simulator", "~model", "~trainer", "~protocol",
            f"dataset.sizes={sizes}", "dataset.chunk_size=2", "threads=1", *overrides,
        )  # fmt: skip
        with open_dict(cfg):
            cfg.simulator = fake_simulator
        return cfg

    return make


def _data_bytes(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob(f"*{SHARD_SUFFIX}"))
    }


def test_plan_covers_every_assembly_once():
    chunks = plan({4: 5, 3: 2}, 2)
    assert [(c.size, c.start, c.stop) for c in chunks] == [
        (3, 0, 2),
        (4, 0, 2),
        (4, 2, 4),
        (4, 4, 5),
    ]
    with pytest.raises(UserError, match="chunk_size"):
        plan({3: 1}, 0)


def test_generate_and_load_are_deterministic(fake_cfg, tmp_path):
    cfg = fake_cfg()
    generation = generate(cfg)
    assert generation.complete and generation.generated == 12
    samples = load_generated(cfg)
    assert [s.size for s in samples] == [3] * 5 + [4] * 4 + [6] * 3
    assert [s.assembly.name for s in samples[:2]] == ["A3-000000", "A3-000001"]
    assert all("seconds" not in s.info for s in samples)
    again = fake_cfg(f"paths.data_dir={tmp_path / 'other'}")
    generate(again)
    assert _data_bytes(dataset_dir(cfg)) == _data_bytes(dataset_dir(again))
    assert load_generated(again) == samples
    other_seed = fake_cfg("dataset.seed=1")
    generate(other_seed)
    assert _data_bytes(dataset_dir(other_seed)) != _data_bytes(dataset_dir(cfg))


def test_distinct_data_set_holds_no_copy_of_the_other(fake_cfg):
    """The selection data set's rule: no assembly in canonical form is also in the data set of
    `distinct_from`; copies are replaced by the next draws, so every count is kept."""
    sizes = "{1: 6, 2: 12}"  # the fake's A1 has 8 layouts, A2 64: copies are frequent
    evaluation = {assembly_key(s) for s in load_generated(fake_cfg(sizes=sizes))}
    plain = load_generated(fake_cfg("dataset.seed=1", sizes=sizes))
    assert sum(assembly_key(s) in evaluation for s in plain) >= 2  # the failure this prevents
    cfg = fake_cfg("dataset.seed=1", "dataset.distinct_from=0", sizes=sizes)
    distinct = load_generated(cfg)
    assert [s.size for s in distinct] == [1] * 6 + [2] * 12
    assert not any(assembly_key(s) in evaluation for s in distinct)
    many = load_generated(fake_cfg("dataset.seed=1", sizes="{1: 60, 2: 60}"))
    first = [  # the first draws of each size that are no copies, in index order
        s for n, count in ((1, 6), (2, 12))
        for s in [s for s in many if s.size == n and assembly_key(s) not in evaluation][:count]
    ]  # fmt: skip
    assert distinct == first
    assert load_generated(cfg) == distinct


@pytest.mark.slow  # draws ten times a size
def test_distinct_data_set_stops_when_the_other_holds_every_layout(fake_cfg):
    with pytest.raises(UserError, match="distinct_from"):  # 40 A1 draws cover all 8 layouts
        load_generated(fake_cfg("dataset.seed=1", "dataset.distinct_from=0", sizes="{1: 40}"))


def test_cache_key_ignores_operational_keys_only(fake_cfg):
    base = dataset_dir(fake_cfg())
    assert (
        dataset_dir(fake_cfg("dataset.chunk_size=7", "dataset.workers=2", sizes="{3: 1}")) == base
    )
    assert dataset_dir(fake_cfg("dataset.num_shards=3", "dataset.shard=2")) == base
    assert dataset_dir(fake_cfg("dataset.seed=5")) != base
    assert dataset_dir(fake_cfg("seed=5")) == base  # the training seed is no data key
    changed = fake_cfg()
    changed.simulator.spacing = 300.0
    assert dataset_dir(changed) != base
    assert base.name.startswith("generated-")


def test_assemblies_do_not_depend_on_chunking(fake_cfg, tmp_path):
    small = load_generated(fake_cfg())
    large = load_generated(fake_cfg("dataset.chunk_size=5", f"paths.data_dir={tmp_path / 'b'}"))
    assert small == large
    subset = load_generated(fake_cfg(sizes="{4: 2}"))
    assert subset == [s for s in small if s.size == 4][:2]


@pytest.mark.slow  # a fast twin covers the behaviour; this one is end to end
def test_two_shards_merge_to_the_unsharded_data_set(fake_cfg, tmp_path):
    whole = fake_cfg(f"paths.data_dir={tmp_path / 'whole'}")
    generate(whole)
    first = generate(fake_cfg("dataset.num_shards=2", "dataset.shard=0"))
    assert not first.complete and first.missing == len(first.chunks) // 2
    second = generate(fake_cfg("dataset.num_shards=2", "dataset.shard=1"))
    assert second.complete
    assert _data_bytes(first.path) == _data_bytes(dataset_dir(whole))
    assert load_generated(fake_cfg()) == load_generated(whole)
    with pytest.raises(UserError, match="shard"):
        generate(fake_cfg("dataset.num_shards=2", "dataset.shard=2"))


def test_loader_fills_the_other_shards_share(fake_cfg):
    generate(fake_cfg("dataset.num_shards=3", "dataset.shard=1"))
    assert len(load_generated(fake_cfg("dataset.num_shards=3", "dataset.shard=1"))) == 12


def test_resume_regenerates_only_missing_chunks(fake_cfg):
    cfg = fake_cfg()
    generation = generate(cfg)
    before = _data_bytes(generation.path)
    lost = generation.chunks[3]
    lost.path(generation.path).unlink()
    assert generate(cfg).generated == lost.stop - lost.start
    assert _data_bytes(generation.path) == before
    assert generate(cfg).generated == 0


def test_worker_processes_give_identical_bytes(fake_cfg, tmp_path):
    one = generate(fake_cfg(f"paths.data_dir={tmp_path / 'one'}"))
    two = generate(fake_cfg(f"paths.data_dir={tmp_path / 'two'}", "dataset.workers=2"))
    assert _data_bytes(one.path) == _data_bytes(two.path)
    by_size = {
        size: [
            t
            for p in sorted((two.path / f"A{size}").glob("*.json"))
            for t in json.loads(p.read_text())["seconds"]
        ]
        for size in (3, 4, 6)
    }
    assert [len(t) for t in by_size.values()] == [5, 4, 3]
    assert seconds_per_assembly(two.path, two.chunks) == {
        size: pytest.approx(sum(t) / len(t)) for size, t in by_size.items()
    }


def test_records_are_lossless(fake_cfg):
    cfg = fake_cfg()
    generation = generate(cfg)
    samples = [s for chunk in generation.chunks for s in read_chunk(chunk, generation.path)]
    moved = samples[0]
    moved.assembly.relations[0, 5] = moved.assembly.relations[5, 0] = 7.25
    assert json.loads(dumps(moved))["relations"] == [[0, 5, 7.25], [5, 0, 7.25]]
    assert loads(dumps(moved)) == moved
    assert "relations" not in json.loads(dumps(samples[1]))


def test_bad_sizes_are_one_clear_error(fake_cfg):
    with pytest.raises(UserError, match=r"dataset\.sizes"):
        generate(fake_cfg(sizes="{3: -1}"))


def test_a_bad_simulator_config_fails_once_in_the_parent(fake_cfg, tmp_path):
    """Built in the parent first: a pool whose worker initializer fails would restart it forever."""
    cfg = fake_cfg(f"paths.data_dir={tmp_path}", "dataset.workers=2")
    with open_dict(cfg):
        cfg.simulator = {"_target_": "grace_tests_conftest.FakeSimulator", "width": 3.0}
    with pytest.raises(Exception, match="width"):
        generate(cfg)
    assert not list(tmp_path.rglob("*.gz"))


REWRITTEN = {
    "rewritten a record short": lambda records, a3: encode_shard(records[:-1]),
    "rewritten with A3's records": lambda records, a3: encode_shard(a3),
    "rewritten with lines that are no records": lambda records, a3: gzip.compress(b'{"a": 1}\n'),
    "rewritten not gzip": lambda records, a3: b"rewritten by hand\n",
}
"""A4 shards rewritten together with the checksum in their manifest, so that only reading them
finds what is wrong; from the chunk's own records and those of the same positions of A3."""


def _damage(chunk, root, how):
    shard, manifest = chunk.path(root), chunk.manifest_path(root)
    if how == "truncated manifest":
        manifest.write_bytes(manifest.read_bytes()[:25])
    elif how == "no manifest":  # killed between the shard and its manifest
        manifest.unlink()
    elif how == "shard and manifest one record short of the chunk":
        data = encode_shard(read_chunk(chunk, root)[:-1])
        node = json.loads(manifest.read_text())
        node["shard"] = ShardInfo.of(data, chunk.count - 1).to_json()
        node["seconds"] = node["seconds"][:-1]
        shard.write_bytes(data)
        manifest.write_text(json.dumps(node))
    elif how in REWRITTEN:
        a3 = Chunk(3, chunk.start, chunk.stop)
        data = REWRITTEN[how](read_chunk(chunk, root), read_chunk(a3, root))
        node = json.loads(manifest.read_text())
        node["shard"]["sha256"] = hashlib.sha256(data).hexdigest()
        shard.write_bytes(data)
        manifest.write_text(json.dumps(node))
    else:
        damage_shard(shard, how, read_chunk(chunk, root))


@pytest.mark.parametrize(
    "how",
    [
        *SHARD_DAMAGE,
        "truncated manifest",
        "no manifest",
        "shard and manifest one record short of the chunk",
        *REWRITTEN,
    ],
)
def test_a_damaged_chunk_is_reported_set_aside_and_generated_again(fake_cfg, how, caplog):
    """Found by the checks before generating (checksum, manifest against its chunk) or, for a
    shard rewritten with its checksum, when read: either way repaired in the same run."""
    cfg = fake_cfg()
    generation = generate(cfg)
    before = _data_bytes(generation.path)
    chunk = generation.chunks[3]  # A4, assemblies 0..1
    _damage(chunk, generation.path, how)
    with caplog.at_level(logging.WARNING, logger="grace.data.store"):
        samples = load_generated(cfg)
    assert [s.size for s in samples] == [3] * 5 + [4] * 4 + [6] * 3
    assert _data_bytes(generation.path) == {
        **before,
        **{k: v for k, v in _data_bytes(generation.path).items() if k.startswith("corrupt")},
    }
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    if how == "no manifest":  # nothing was damaged: the chunk was never finished
        assert warnings == []
    else:
        assert len(warnings) == 1 and "\n" not in warnings[0]
        assert warnings[0].startswith(f"{generation.path}/A4/000000-000002.")
        assert "generating it again" in warnings[0]
        assert list((generation.path / "corrupt" / "A4").iterdir())


def test_a_chunk_still_wrong_once_generated_again_is_one_line_with_the_fix(fake_cfg, monkeypatch):
    """Found wrong when read, set aside, generated again and still wrong (here a simulator that
    makes assemblies a part short): one line, not a loop."""
    cfg = fake_cfg()
    generation = generate(cfg)
    chunk = generation.chunks[3]
    _damage(chunk, generation.path, "rewritten with A3's records")
    simulator = importlib.import_module("grace_tests_conftest").FakeSimulator
    sample = simulator.sample
    monkeypatch.setattr(simulator, "sample", lambda self, n, rng: sample(self, n - 1, rng))
    with pytest.raises(UserError) as error:
        load_generated(cfg)
    assert str(error.value) == (
        f"{chunk.path(generation.path)}: shard holds assemblies of size [3], its chunk is A4; "
        "fix: rerun, which moves it aside and generates it again"
    )


def _generate_at(cfg, barrier, counts):
    barrier.wait()
    counts.put(generate(cfg).generated)


@pytest.mark.slow  # two processes; the claims' takeover rules have fast tests here
def test_two_processes_generating_one_data_set_share_the_work(fake_cfg, tmp_path):
    """Started together on 40 assemblies (20 chunks) of a slowed-down simulator: every chunk is
    generated once, by one of them, each does a fair share, and the bytes are the usual ones."""
    sizes = "{3: 20, 4: 20}"
    cfg = fake_cfg(f"paths.data_dir={tmp_path / 'shared'}", sizes=sizes)
    with open_dict(cfg):
        cfg.simulator.delay = 0.02
    ctx = mp.get_context("fork")
    barrier, counts = ctx.Barrier(2), ctx.Queue()
    runs = [ctx.Process(target=_generate_at, args=(cfg, barrier, counts)) for _ in range(2)]
    for run in runs:
        run.start()
    for run in runs:
        run.join(timeout=120)
    generated = sorted(counts.get(timeout=1) for _ in runs)
    assert sum(generated) == 40 and generated[0] >= 10, generated
    alone = fake_cfg(f"paths.data_dir={tmp_path / 'alone'}", sizes=sizes)
    with open_dict(alone):
        alone.simulator.delay = 0.02
    generate(alone)
    assert _data_bytes(dataset_dir(cfg)) == _data_bytes(dataset_dir(alone))


def test_a_claim_of_a_dead_process_is_taken_over_and_a_live_one_respected(fake_cfg):
    cfg = fake_cfg()
    root = dataset_dir(cfg)
    first, second = plan({3: 5, 4: 4, 6: 3}, 2)[:2]
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], text=True,
                          capture_output=True, check=True)  # fmt: skip
    first.claim_path(root).parent.mkdir(parents=True)
    first.claim_path(root).write_text(
        json.dumps({"host": socket.gethostname(), "pid": int(dead.stdout)})
    )
    assert generate(cfg).complete
    assert not list(root.rglob("*.claim*"))
    second.manifest_path(root).unlink()
    second.claim_path(root).write_text(json.dumps({"host": socket.gethostname(), "pid": 1}))
    assert not claims.claim(second.claim_path(root))  # pid 1 lives: the chunk is its
    waiting = ThreadPoolExecutor(1).submit(generate, cfg)
    time.sleep(1.0)
    assert not waiting.done()  # waits for the live owner's chunk
    second.claim_path(root).unlink()  # the owner gave up without finishing
    assert waiting.result(timeout=30).generated == second.count


def _files(folder: Path) -> dict[str, bytes | None]:
    """Every path under `folder` with its bytes (None for a folder)."""
    return {str(p.relative_to(folder)): None if p.is_dir() else p.read_bytes()
            for p in sorted(folder.rglob("*"))}  # fmt: skip


def _fix_after_refusal(cfg, intact: dict[str, bytes], expected: str, fix) -> None:
    """The run is refused in one line matching `expected` with nothing written; after `fix()`
    (what the line says to do) it loads the data set and the shards are the `intact` ones."""
    data = Path(cfg.paths.data_dir)
    before = _files(data)
    with pytest.raises(UserError) as error:
        generate(cfg)
    assert "\n" not in str(error.value) and re.search(expected, str(error.value)), error.value
    assert _files(data) == before
    fix()
    assert len(load_generated(cfg)) == 12
    shards = _data_bytes(dataset_dir(cfg))
    assert {k: v for k, v in shards.items() if not k.startswith("corrupt")} == intact


@pytest.mark.parametrize("file", ["shard", "manifest", "claim"])
def test_a_folder_where_a_chunk_file_belongs_is_refused_with_the_fix(fake_cfg, file):
    """Not left by a crash or a bad copy: the run names it rather than moving someone's folder
    (the chunk's manifest still exists for the shard and the claim)."""
    cfg = fake_cfg()
    generation = generate(cfg)
    intact = _data_bytes(generation.path)
    chunk = generation.chunks[3]
    path = {"shard": chunk.path, "manifest": chunk.manifest_path, "claim": chunk.claim_path}
    folder = path[file](generation.path)
    folder.unlink(missing_ok=True)
    (folder / "inside").mkdir(parents=True)
    _fix_after_refusal(
        cfg,
        intact,
        rf"^{folder} is a folder where a file of the data set belongs; fix: move it away or "
        r"delete it: its chunk is then generated again$",
        lambda: shutil.rmtree(folder),
    )


@pytest.mark.parametrize("where", ["corrupt", "A4", "corrupt/A4"])
def test_a_file_where_a_folder_of_the_data_set_belongs_is_refused_with_the_fix(fake_cfg, where):
    """`corrupt` (or its A4) a file while a damaged A4 chunk must be moved there; `A4` a file
    while its chunks must be written there."""
    cfg = fake_cfg()
    generation = generate(cfg)
    root = generation.path
    intact = _data_bytes(root)
    if where == "A4":
        shutil.rmtree(root / "A4")
    else:
        _damage(generation.chunks[3], root, "half")
        (root / where).parent.mkdir(parents=True, exist_ok=True)
    (root / where).write_text("in the way\n")
    _fix_after_refusal(
        cfg,
        intact,
        rf"^{root / where} is a file where a folder of the data set belongs \(.*\); fix: move it "
        r"away or delete it: the run makes the folder$",
        (root / where).unlink,
    )


def test_a_folder_the_run_must_write_into_that_refuses_files_is_named_with_the_fix(
    fake_cfg, lock_folder
):
    """A chunk of A4 is missing and A4/ refuses new files: its claim could not be written."""
    cfg = fake_cfg()
    generation = generate(cfg)
    intact = _data_bytes(generation.path)
    folder = generation.path / "A4"
    generation.chunks[3].manifest_path(generation.path).unlink()
    unlock = lock_folder(folder)
    _fix_after_refusal(
        cfg,
        intact,
        rf"^{folder} is not writable \(.*\), and this run writes the chunk's claim, shard and "
        rf"manifest there; fix: make it writable \(chmod u\+w {folder}\)",
        unlock,
    )
    assert not list(folder.glob("*.claim"))


@pytest.mark.parametrize("idle", [60.0, 0.0], ids=["left a minute ago", "touched just now"])
def test_an_empty_claim_left_by_a_stopped_run_is_taken_over(fake_cfg, caplog, monkeypatch, idle):
    """A run stopped between creating a claim and writing its owner leaves it empty; `touch`
    makes one just now. The rerun takes the first over at once; it names the second and how long
    it waits (claims.WRITE_SECONDS, shortened here), then takes it over."""
    monkeypatch.setattr(claims, "WRITE_SECONDS", 0.5, raising=False)
    cfg = fake_cfg()
    generation = generate(cfg)
    chunk = generation.chunks[3]
    for path in (chunk.path(generation.path), chunk.manifest_path(generation.path)):
        path.unlink()
    claim = chunk.claim_path(generation.path)
    claim.touch()
    os.utime(claim, (time.time() - idle,) * 2)
    with caplog.at_level(logging.INFO, logger="grace.data.store"):
        rerun = ThreadPoolExecutor(1).submit(generate, cfg)
        assert rerun.result(timeout=30).generated == chunk.count
    waits = [r.getMessage() for r in caplog.records if r.getMessage().startswith("waiting")]
    named = f"waiting for {claim}: names no owner (empty); taken over once 0.5 s old"
    assert waits == ([named] if idle == 0 else [])
    assert not list(generation.path.rglob("*.claim*"))
