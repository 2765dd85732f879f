"""The sweep configs compose and run as Hydra multiruns, and gather reads what they write."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def grace(*args: str, timeout: int) -> None:
    """`python -m grace` with the args, from the repository (where `sweeps/` lies)."""
    subprocess.run(
        [sys.executable, "-m", "grace", *args],
        cwd=ROOT,
        check=True,
        capture_output=True,
        timeout=timeout,
    )


def gather(sweep: Path, out: Path, common: list[str]) -> None:
    grace("task=gather", f"task.roots=[{sweep}]", f"hydra.run.dir={out}", *common, timeout=120)


@pytest.mark.slow
def test_table3_sweep_runs_both_models_and_gathers(tmp_path):
    sweep = tmp_path / "sweep"
    common = [f"paths.data_dir={tmp_path / 'data'}"]
    grace(
        *("--config-dir", "sweeps", "--config-name", "table3"),
        *("scale=smoke", "protocol.folds=2", "trainer.max_epochs=1", "train_size=4"),
        f"hydra.sweep.dir={sweep}",
        *common,
        timeout=300,
    )
    runs = sorted(sweep.glob("*/results.json"))
    models = {json.loads(p.read_text())["run"]["model"] for p in runs}
    assert len(runs) == 2 and models == {"grace", "grace_geometric"}
    gathered = tmp_path / "gather"
    gather(sweep, gathered, common)
    table = (gathered / "gather.md").read_text()
    assert "## Table 3: one-to-many" in table
    assert "| model=grace | A4 |" in table and "| model=grace_geometric | A4 |" in table


@pytest.mark.slow
def test_seed_sweep_keeps_the_data_and_gathers_into_one_pooled_block(tmp_path):
    sweep = tmp_path / "sweep"
    common = [f"paths.data_dir={tmp_path / 'data'}"]
    grace(
        *("--config-dir", "sweeps", "--config-name", "seeds"),
        *("scale=smoke", "protocol.folds=2", "trainer.max_epochs=1"),
        f"hydra.sweep.dir={sweep}",
        *common,
        timeout=300,
    )
    runs = [json.loads(p.read_text()) for p in sorted(sweep.glob("*/results.json"))]
    assert sorted(r["run"]["seed"] for r in runs) == [0, 1, 2]
    assert {r["run"]["data_seed"] for r in runs} == {0}
    assert len(list((tmp_path / "data").iterdir())) == 1  # one data set for every seed
    gathered = tmp_path / "gather"
    gather(sweep, gathered, common)
    table2 = json.loads((gathered / "gather.json").read_text())["table2"]
    pooled = table2["GRACE (3 seeds)"]["intra"]
    assert all(entry["step_auc"]["runs"] == 3 for entry in pooled.values())


@pytest.mark.slow
def test_upward_sweep_extends_table3(tmp_path):
    sweep = tmp_path / "sweep"
    common = [f"paths.data_dir={tmp_path / 'data'}"]
    grace(
        *("--config-dir", "sweeps", "--config-name", "upward"),
        "dataset.sizes={3: 4, 4: 4, 5: 4, 6: 4, 7: 4, 8: 2, 10: 2, 12: 2}",
        *("protocol.folds=2", "trainer.max_epochs=1", "task.recording.per_size=0"),
        f"hydra.sweep.dir={sweep}",
        *common,
        timeout=600,
    )
    runs = [json.loads(p.read_text()) for p in sorted(sweep.glob("*/results.json"))]
    assert {r["protocol"] for r in runs} == {"upward"} and len(runs) == 2
    assert all(r["test_sizes"] == [8, 10, 12] for r in runs)
    gathered = tmp_path / "gather"
    gather(sweep, gathered, common)
    table = (gathered / "gather.md").read_text()
    assert "| model=grace | A3+4+5+6+7 |" in table and "## Table 3, every metric" in table
