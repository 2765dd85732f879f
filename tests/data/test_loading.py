import shutil

import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import open_dict

from grace.data import loading
from grace.data.loading import RawSource
from grace.data.raw_format import RawFormatError, export_raw
from grace.data.store import GeneratedSource
from grace.errors import UserError

DROP = ("task=generate", "~simulator", "~model", "~trainer", "~protocol")


def load_dataset(cfg):
    return instantiate(cfg.dataset).load()


@pytest.fixture
def raw_tree(tmp_path, fake_simulator):
    """A folder of raw assembly folders (sizes 3 and 5, three each) and their samples in order."""
    simulator = instantiate(fake_simulator)
    samples = []
    for size in (5, 3):
        for i in range(3):
            sample = simulator.sample(size, np.random.default_rng([size, i]))
            sample.assembly.name, sample.info = f"{size}_{i}", {}
            export_raw(sample, tmp_path / "raw" / f"A{size}" / sample.assembly.name)
            samples.append(sample)
    return tmp_path / "raw", sorted(samples, key=lambda s: (s.size, s.assembly.name))


def test_raw_data_set_is_imported_and_cached(cfg_factory, raw_tree, tmp_path, monkeypatch):
    root, expected = raw_tree
    cfg = cfg_factory("dataset=raw", f"dataset.path={root}", "dataset.sizes=null", *DROP)
    loaded = load_dataset(cfg)
    assert loaded == expected
    assert [s.assembly.name for s in loaded] == ["3_0", "3_1", "3_2", "5_0", "5_1", "5_2"]
    (cache,) = (tmp_path / "data").iterdir()
    assert cache.name.startswith("raw-") and (cache / "manifest.json").exists()
    with monkeypatch.context() as patch:
        patch.setattr(loading, "import_raw_folders", None)  # a second import would fail
        assert load_dataset(cfg) == expected  # from the cache
    (root / "A3" / "3_1" / "solutions.csv").write_text("")
    assert len(list((tmp_path / "data").iterdir())) == 1
    reloaded = load_dataset(cfg)  # an edited folder is imported again
    assert not reloaded[1].truth.feasible and len(list((tmp_path / "data").iterdir())) == 2


@pytest.mark.parametrize(
    "damage",
    ["half a shard", "empty shard", "truncated manifest", "shard a folder", "manifest a folder"],
)
def test_a_damaged_raw_cache_is_refused_in_one_line_with_the_fix(
    cfg_factory, raw_tree, tmp_path, damage
):
    """Imported raw data cannot be made again from a seed: the cache is refused, not repaired,
    and the line says how to import it again, which works."""
    root, expected = raw_tree
    cfg = cfg_factory("dataset=raw", f"dataset.path={root}", "dataset.sizes=null", *DROP)
    load_dataset(cfg)
    (cache,) = (tmp_path / "data").iterdir()
    shard, manifest = cache / "A5.jsonl.gz", cache / "manifest.json"
    if damage == "half a shard":
        shard.write_bytes(shard.read_bytes()[: shard.stat().st_size // 2])
    elif damage == "empty shard":
        shard.write_bytes(b"")
    elif damage.endswith("a folder"):
        path = shard if damage.startswith("shard") else manifest
        path.unlink()
        path.mkdir()
    else:
        manifest.write_text(manifest.read_text()[:30])
    with pytest.raises(UserError) as error:
        load_dataset(cfg)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(str(shard if "shard" in damage else manifest))
    assert message.endswith(f"fix: delete {cache} and rerun: the raw folders under {root} are "
                            "imported again")  # fmt: skip
    with pytest.raises(UserError):  # task=... counts() reads the cache the same way
        instantiate(cfg.dataset).counts()
    shutil.rmtree(cache)
    assert load_dataset(cfg) == expected


def test_raw_sizes_select_the_first_of_each_size(cfg_factory, raw_tree):
    root, expected = raw_tree
    cfg = cfg_factory(
        "dataset=raw",
        f"dataset.path={root}",
        "dataset.sizes={5: 2, 4: 1}",
        *DROP,
    )
    assert load_dataset(cfg) == [s for s in expected if s.size == 5][:2]


def test_malformed_raw_tree_writes_nothing(cfg_factory, raw_tree, tmp_path):
    root, _ = raw_tree
    (root / "A5" / "5_2" / "distances.csv").write_text("part_0_surface_1,part_9_surface_1,4\n")
    (root / "A3" / "3_0" / "assembly.spec").write_text("")
    cfg = cfg_factory("dataset=raw", f"dataset.path={root}", *DROP)
    with pytest.raises(RawFormatError) as error:
        load_dataset(cfg)
    assert str(error.value).splitlines() == [
        f"2 of 6 raw folders under {root} are malformed: {root}/A3/3_0/assembly.spec: file is "
        "empty; fix: write 'begin Pieces', one line per part, 'end Pieces'",
        f"{root}/A5/5_2/distances.csv:1: surface 'part_9_surface_1' is not a surface of a part in "
        "assembly.spec; fix: name surfaces '<part>_surface_<k>' after a listed part, k within its "
        "surfaces",
    ]
    assert not (tmp_path / "data").exists() or not any((tmp_path / "data").iterdir())


def test_dataset_errors_name_the_fix(cfg_factory):
    with pytest.raises(UserError, match=r"dataset\.path"):
        load_dataset(cfg_factory("dataset=raw", *DROP))


def test_the_dataset_group_chooses_the_source(cfg_factory, fake_simulator):
    assert isinstance(instantiate(cfg_factory("dataset=raw", *DROP).dataset), RawSource)
    cfg = cfg_factory("dataset.sizes={4: 3}", "threads=1", *DROP)
    with open_dict(cfg):
        cfg.simulator = fake_simulator
    source = instantiate(cfg.dataset)
    assert isinstance(source, GeneratedSource) and source.simulator == dict(fake_simulator)
    assert [s.size for s in source.load()] == [4, 4, 4]
