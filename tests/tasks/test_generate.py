import json
import math
from pathlib import Path

import pytest
from hydra.utils import instantiate
from omegaconf import open_dict

from grace.data.raw_format import import_raw
from grace.errors import UserError
from grace.tasks.generate import pick_examples, run

# Groups task=generate does not use; dropping them keeps this test independent of their configs.
UNUSED = ("~model", "~trainer", "~protocol")


def load_generated(cfg):
    return instantiate(cfg.dataset).load()


SIZE_KEYS = {
    "assemblies": int, "infeasible_fraction": float, "orders_mean": float, "orders_median": float,
    "multi_order_fraction": float, "infeasible_causes": dict, "robot_pruned_fraction": float,
    "infeasible_mechanisms": dict, "rule_decisive_fraction": dict,
    "nonlocal_block_fraction": float, "states": int, "naive_checks": int, "checks": int,
    "exact_copies": int, "renumbered_copies": int,
}  # fmt: skip


def assert_stats_schema(stats: dict, sizes: dict[int, int]) -> None:
    """stats.json: its keys, types and ranges; null only where there is nothing to average."""
    assert set(stats) == {"per_size", "seconds_per_assembly", "dataset_path"}
    assert list(stats["per_size"]) == [str(n) for n in sorted(sizes)]
    assert list(stats["seconds_per_assembly"]) == list(stats["per_size"])
    assert all(s > 0 for s in stats["seconds_per_assembly"].values())
    assert Path(stats["dataset_path"]).is_dir()
    for size, entry in stats["per_size"].items():
        assert set(entry) == set(SIZE_KEYS)
        assert entry["assemblies"] == sizes[int(size)]
        for key, kind in SIZE_KEYS.items():
            value = entry[key]
            assert (
                value is None
                or isinstance(value, kind)
                or (kind is float and isinstance(value, int))
            ), key
        assert set(entry["infeasible_causes"]) == {"reach", "collision", "other"}
        fractions = [
            entry[k] for k in SIZE_KEYS if k.endswith("fraction") and SIZE_KEYS[k] is float
        ]
        for shares in ("infeasible_causes", "infeasible_mechanisms", "rule_decisive_fraction"):
            fractions += list(entry[shares].values())
        assert all(f is None or 0 <= f <= 1 for f in fractions)
        causes = [f for f in entry["infeasible_causes"].values() if f is not None]
        assert not causes or math.isclose(sum(causes), 1.0)
        assert entry["checks"] <= entry["naive_checks"]
        assert entry["states"] >= entry["assemblies"]


@pytest.mark.slow  # end to end; CI's installed-copy run does it again
def test_generate_smoke_end_to_end(cfg_factory, tmp_path):
    """`python -m grace task=generate scale=smoke` with the real simulator, in tmp_path."""
    cfg = cfg_factory(
        "task=generate", "scale=smoke", "task.export_raw=" + str(tmp_path / "raw"), *UNUSED
    )
    assert run(cfg) is None
    out = tmp_path / "output"
    stats = json.loads((out / "stats.json").read_text())
    sizes = {int(k): int(v) for k, v in cfg.scale.sizes.items()}
    assert_stats_schema(stats, sizes)
    assert (out / "topview.png").read_bytes().startswith(b"\x89PNG")
    tables = (out / "stats.md").read_text()
    a5 = stats["per_size"]["5"]
    assert f"| A5 | {sizes[5]} | {a5['infeasible_fraction']:.2f} |" in tables
    fixation = f"| fixation | {stats['per_size']['3']['rule_decisive_fraction']['fixation']:.2f} |"
    assert fixation in tables
    samples = load_generated(cfg)
    assert stats["per_size"]["5"]["infeasible_fraction"] == pytest.approx(
        sum(not s.truth.feasible for s in samples if s.size == 5) / sizes[5]
    )
    exported = import_raw(tmp_path / "raw" / "A7" / samples[-1].assembly.name)
    assert exported.assembly == samples[-1].assembly and exported.truth == samples[-1].truth


@pytest.mark.slow  # a fast twin covers the behaviour; this one is end to end
def test_sharded_runs_write_stats_once_complete(cfg_factory, fake_simulator):
    def cfg_for(shard: int):
        cfg = cfg_factory(
            "task=generate", "scale=smoke", "~simulator", "threads=1", "dataset.chunk_size=4",
            "dataset.num_shards=2", f"dataset.shard={shard}", *UNUSED,
        )  # fmt: skip
        with open_dict(cfg):
            cfg.simulator = fake_simulator
        return cfg

    run(cfg_for(0))
    out = Path(cfg_for(0).paths.output_dir)
    assert not (out / "stats.json").exists()
    run(cfg_for(1))
    stats = json.loads((out / "stats.json").read_text())
    assert_stats_schema(stats, {int(k): int(v) for k, v in cfg_for(1).scale.sizes.items()})


def test_pick_examples_mixes_feasible_and_infeasible(cfg_factory, fake_simulator):
    cfg = cfg_factory("task=generate", "scale=smoke", "~simulator", "threads=1", *UNUSED)
    with open_dict(cfg):
        cfg.simulator = fake_simulator
    samples = load_generated(cfg)
    picked = pick_examples(samples, 4)
    assert [s.size for s in picked] == [7, 7, 6, 6]
    assert [s.truth.feasible for s in picked] == [True, False, True, False]
    assert pick_examples(samples, 0) == []


def test_generate_rejects_raw_dataset(cfg_factory):
    with pytest.raises(UserError, match="dataset=generated"):
        run(cfg_factory("task=generate", "dataset=raw", *UNUSED))


@pytest.mark.slow  # a fast twin covers the behaviour; this one is end to end
def test_real_simulator_bytes_do_not_depend_on_workers(cfg_factory, tmp_path):
    def shard_bytes(workers: int) -> list[bytes]:
        cfg = cfg_factory(
            "task=generate", "dataset.sizes={4: 3, 6: 3}", "dataset.chunk_size=2",
            f"dataset.workers={workers}", f"paths.data_dir={tmp_path / str(workers)}", *UNUSED,
        )  # fmt: skip
        generation = instantiate(cfg.dataset).generate()
        return [chunk.path(generation.path).read_bytes() for chunk in generation.chunks]

    assert shard_bytes(1) == shard_bytes(2)
