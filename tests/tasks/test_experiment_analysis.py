import json

import experiment_fakes
import pytest

from grace.tasks.experiment import run


def test_experiment_writes_strict_figures_floors_failures_and_feasibility(tmp_path, fake_cfg):
    experiment_fakes.FITS.clear()
    run(fake_cfg(tmp_path, "intra"))
    results = json.loads((tmp_path / "results.json").read_text())
    assert set(results["baselines"]) == {"random", "constant", "never"}
    for size, entry in results["per_size"].items():
        assert entry["p_at_k_strict"]["1"]["mean"] <= entry["p_at_k"]["1"]["mean"]
        assert "best_sequence" in entry["feasibility"]["schemes"]
        never = results["baselines"]["never"]["per_size"][size]
        assert never["seq_auc"]["mean"] == pytest.approx(0.5)
        assert never["p_at_k_strict"]["1"]["mean"] == 0.0 and never["p_at_k"]["1"]["mean"] == 1.0
    assert results["collapsed_folds"] == [] and len(results["fold_health"]) == 4
    assert results["fold_health"][0]["training"] == "no training log found"  # the fake fit
    failures = json.loads((tmp_path / "failures.json").read_text())
    assert set(failures["per_size"]) == set(results["per_size"])
    feasibility = json.loads((tmp_path / "feasibility.json").read_text())
    assert feasibility["max_fpr"] == 0.05
    for name in ("failures.png", "feasibility_roc.png"):
        assert (tmp_path / name).read_bytes()[:4] == b"\x89PNG"
    md = (tmp_path / "results.md").read_text()
    assert "## Feasibility (GRACE)" in md and "## Folds" in md


@pytest.mark.slow  # a fast twin covers the behaviour; this one is end to end
def test_a_fold_no_better_than_the_floors_is_flagged(tmp_path, fake_cfg):
    cfg = fake_cfg(tmp_path, "intra")
    # "trained" into a constant
    cfg.task.scorer = {"_target_": "grace.evaluation.baselines.constant_scorer", "_partial_": True}
    run(cfg)
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["collapsed_folds"] == [0, 1, 2, 3]
    assert "**Warning: folds [0, 1, 2, 3] collapsed**" in (tmp_path / "results.md").read_text()
