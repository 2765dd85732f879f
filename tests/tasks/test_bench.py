import json
from pathlib import Path

import pytest
from omegaconf import open_dict

from grace.tasks.bench import run


def _bench_cfg(cfg_factory, fake_simulator, *overrides: str):
    """A task=bench config on the simulator stand-in, one thread, small batches."""
    cfg = cfg_factory("task=bench", "datamodule.batch_size=16", "threads=1", *overrides)
    with open_dict(cfg):
        cfg.simulator = fake_simulator
    return cfg


@pytest.mark.slow  # a benchmark's figures: two trainings side by side
@pytest.mark.parametrize(
    ("model", "params"),
    [("grace", 51_701), ("grace_geometric", 137_178)],
)
def test_bench_writes_side_by_side_figures(cfg_factory, fake_simulator, model, params):
    """The paper's network and the default (two outputs: the benchmark trains with its loss)."""
    cfg = _bench_cfg(
        cfg_factory, fake_simulator, f"model={model}", "task.assemblies=3",
        "task.train_steps=2", "task.infer_calls=3", "task.prefix_passes=5",
        "task.compile_backend=eager",
    )  # fmt: skip
    speedup = run(cfg)
    bench = json.loads(Path(cfg.paths.output_dir, "bench.json").read_text())
    assert bench["params"] == params
    assert set(bench["train_graphs_per_s"]) == {"pyg", "fast"}
    assert all(v > 0 for v in bench["train_graphs_per_s"].values())
    for impl in ("pyg", "fast"):
        assert bench["infer_ms_per_state"][impl]["7"] > 0
    for impl in ("fast", "compiled"):
        assert bench["infer_ms_per_state_warm"][impl]["7"] > 0
    assert bench["infer_ms_per_state"]["compiled"]["7"] > 0 and bench["compile_s"] > 0
    table = Path(cfg.paths.output_dir, "inference.md").read_text()
    assert "| compiled | A7 |" in table and "| pyg | A7 |" in table
    assert set(bench["evaluate_ms_per_assembly"]) == {"GRACE", "random", "constant", "never"}
    assert all(v["7"] > 0 for v in bench["evaluate_ms_per_assembly"].values())
    assert speedup == bench["train_graphs_per_s"]["fast"] / bench["train_graphs_per_s"]["pyg"]
    for impl in ("pyg", "fast"):
        planning = bench["planning"][impl]
        assert planning["n_parts"] == 7 and planning["prefix_passes_measured"] == 5


def test_profile_times_the_first_folds_epochs(cfg_factory, fake_simulator, capsys):
    cfg = _bench_cfg(
        cfg_factory, fake_simulator, "task.profile=true", "task.profile_epochs=1",
        "dataset.sizes={3: 8, 4: 8}", "trainer.enable_progress_bar=false",
    )  # fmt: skip
    epoch_cpu_s = run(cfg)
    profile = json.loads(Path(cfg.paths.output_dir, "profile.json").read_text())
    assert profile["epochs"] == 1 and profile["threads"] == 1
    assert profile["assemblies"]["train"] > 0 and profile["assemblies"]["val"] > 0
    assert epoch_cpu_s == pytest.approx(sum(profile["cpu_s_per_epoch"].values()))
    assert profile["cpu_s_per_epoch"]["backward"] > 0
    assert "backward" in capsys.readouterr().out
