import json

import pytest

from grace.tasks.experiment import run


@pytest.mark.slow  # a fast twin covers the behaviour; this one is end to end
def test_a_fold_no_better_than_the_floors_is_flagged(tmp_path, fake_cfg):
    cfg = fake_cfg(tmp_path, "intra")
    # "trained" into a constant
    cfg.task.scorer = {"_target_": "grace.evaluation.baselines.constant_scorer", "_partial_": True}
    run(cfg)
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["collapsed_folds"] == [0, 1, 2, 3]
    assert "**Warning: folds [0, 1, 2, 3] collapsed**" in (tmp_path / "results.md").read_text()
