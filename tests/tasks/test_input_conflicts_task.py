"""task=input_conflicts: every test step counted once over the folds, the report written."""

import json

import pytest
from omegaconf import open_dict

from grace.tasks.input_conflicts import run


@pytest.mark.slow  # end to end (15 s: generates its data set); its counting has fast tests
def test_input_conflicts_counts_every_test_step_once(cfg_factory, fake_simulator, tmp_path):
    cfg = cfg_factory(
        "task=input_conflicts",
        "dataset.sizes={3: 6, 4: 6}",
        "protocol.folds=2",
        "threads=1",
        "task.moves=[[50.0, 0.0]]",
        "task.moved_per_size=2",
    )
    with open_dict(cfg):
        cfg.simulator = fake_simulator
    run(cfg)
    out = tmp_path / "output"
    report = json.loads((out / "input_conflicts.json").read_text())
    assert report["states"] == "reachable" and report["folds"] == 2
    for size in ("3", "4"):  # intra: each assembly is a test assembly of exactly one fold
        assert report["test"][size]["steps"] == report["within"][size]["steps"] > 0
        assert report["test"][size]["label_conflicts"] <= report["test"][size]["seen_in_training"]
    assert report["moves"]["3"]["moved"] == 2  # two A3 assemblies, one shift each
    table = (out / "input_conflicts.md").read_text()
    assert table.startswith("|  | A3 | A4 |") and "Bayes ceiling on the test steps" in table
