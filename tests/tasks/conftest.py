"""Fixtures of the task tests."""

import pytest
from omegaconf import open_dict


@pytest.fixture
def fake_cfg(cfg_factory):
    """The experiment on precedence puzzles, a near-oracle policy and no training."""

    def make(out, protocol: str, *overrides: str):
        cfg = cfg_factory(
            f"paths.output_dir={out}", f"protocol={protocol}", "threads=1", "train_size=4",
            "test_size=4", "task.fold_jobs=1", *overrides,
        )  # fmt: skip
        with open_dict(cfg):  # FITS records the fits of this process (fold_jobs=1)
            cfg.dataset = {"_target_": "experiment_fakes.PuzzleSource", "seed": 0}
            cfg.task.fit = {"_target_": "experiment_fakes.fit", "_partial_": True}
            cfg.task.scorer = {"_target_": "experiment_fakes.make_scorer", "_partial_": True}
        return cfg

    return make
