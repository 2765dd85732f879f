import json
from pathlib import Path

import experiment_fakes
import pytest

from grace.tasks.feasibility import FEASIBLE_ONLY, run

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)


def test_feasibility_task_trains_both_models_and_writes_every_scheme(tmp_path, fake_cfg):
    cfg = fake_cfg(
        tmp_path,
        "intra",
        "task=feasibility",
        "task.classifiers=null",  # the fakes have no embeddings: classifiers and densities
        "task.densities=null",  # are covered in tests/evaluation/test_feasibility.py
    )
    experiment_fakes.FITS.clear()
    objective = run(cfg)
    out = Path(cfg.paths.output_dir)
    report = json.loads((out / "feasibility.json").read_text())
    # per fold: one model on every training assembly, one on the feasible ones only
    assert len(experiment_fakes.FITS) == 8
    all_fits, feasible_fits = experiment_fakes.FITS[0::2], experiment_fakes.FITS[1::2]
    assert all(f[0] < a[0] for f, a in zip(feasible_fits, all_fits, strict=True))
    assert set(report["per_size"]) == {"3", "4", "5"}
    names = set(report["per_size"]["5"])
    assert names == {
        "sequences",
        "best_sequence",
        "bottleneck",
        *(FEASIBLE_ONLY + n for n in ("sequences", "best_sequence", "bottleneck")),
    }
    entry = report["per_size"]["5"]["best_sequence"]
    assert entry["roc_auc"]["mean"] == pytest.approx(1.0)  # the near-oracle policy
    # two of the four A5 test folds of the fake data hold both classes; ROC is undefined in the
    # others, which the report leaves out rather than count as 0 or 1
    assert entry["folds"] == 2 and len(entry["roc"]["fpr"]) == len(entry["roc"]["tpr"])
    assert objective == pytest.approx(1.0)
    assert len(report["health"]) == 8 and report["health"][1]["model"] == "feasible-only GRACE"
    md = (out / "results.md").read_text()
    assert "| best_sequence | 1.00 ± 0.00 / 1.00 |" in md
    assert (out / "feasibility_roc.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow
def test_feasibility_task_end_to_end_on_simulator_data(cfg_factory):
    """Real data, training, pooled embeddings, classifiers and densities (a minute or so)."""
    cfg = cfg_factory(
        "task=feasibility",
        "scale=smoke",
        "scale.sizes={5: 48, 6: 48}",  # ~10 % infeasible: both classes in every test fold
        "protocol.train_sizes=[5,6]",
        "protocol.test_sizes=[5,6]",
        "protocol.folds=2",
        "trainer.max_epochs=2",
        "trainer.enable_progress_bar=false",
        "task.fold_jobs=1",
    )
    run(cfg)
    report = json.loads((Path(cfg.paths.output_dir) / "feasibility.json").read_text())
    schemes = set(report["per_size"]["6"])
    assert {
        "best_sequence",
        "classifier: svm_linear",
        "density: flow",
        "density: gaussian",
    } <= schemes
    assert {FEASIBLE_ONLY + "best_sequence", FEASIBLE_ONLY + "density: flow"} <= schemes
    assert not any(name.startswith(FEASIBLE_ONLY + "classifier") for name in schemes)
