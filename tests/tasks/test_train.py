import json
import math
from pathlib import Path

import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import open_dict

from grace.evaluation.protocols import split_assemblies
from grace.evaluation.step_states import state_scores
from grace.model.module import GraceModule
from grace.model.scoring import make_scorer
from grace.tasks.train import run

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)


def _pr_area(scores: np.ndarray, labels: np.ndarray) -> float:
    """Area under the precision-recall points of every threshold, from (recall 0, precision 1),
    by the trapezoid rule: the step AUC of docs/metrics.md written out."""
    recall, precision = [0.0], [1.0]
    for t in np.unique(scores)[::-1]:
        chosen = scores >= t
        hits = (chosen & labels).sum()
        recall.append(hits / labels.sum())
        precision.append(hits / chosen.sum())
    return float(np.trapezoid(precision, recall))


@pytest.fixture
def samples_by_size(fake_simulator):
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(0)
    return [simulator.sample(n, rng) for n in (3, 4, 5) for _ in range(10)]


def test_task_train_writes_checkpoint_and_metrics(cfg_factory, fake_simulator, capsys):
    cfg = cfg_factory(
        "task=train",
        "dataset.sizes={3: 8, 4: 8}",
        "threads=1",
        "trainer.max_epochs=2",
        "trainer.enable_progress_bar=false",
    )
    with open_dict(cfg):
        cfg.simulator = fake_simulator
    auc = run(cfg)
    out = capsys.readouterr().out
    assert "A3: held-out step AUC" in out and "A4: held-out step AUC" in out
    metrics = json.loads(Path(cfg.paths.output_dir, "metrics.json").read_text())
    assert metrics["params"] == 137_178  # the default model: grace_geometric
    assert set(metrics["step_auc"]["per_size"]) == {"3", "4"}
    assert metrics["assemblies"]["test"] >= 2
    assert metrics["checkpoint"].endswith("best.ckpt")
    # The returned AUC, recomputed another way: the held-out split again, the weights reloaded
    # from the checkpoint, the precision-recall area by hand.
    data = instantiate(cfg.dataset).load()
    _, _, test = split_assemblies(data, cfg.task.test_fraction, cfg.task.val_fraction, cfg.seed)
    reloaded = GraceModule.load_from_checkpoint(metrics["checkpoint"], weights_only=False).eval()
    scores, labels = state_scores(make_scorer(reloaded), test)
    expected = _pr_area(scores, labels.astype(bool)) if labels.any() else math.nan
    assert auc == pytest.approx(expected, abs=1e-9, nan_ok=True)
    assert metrics["step_auc"]["all"] == (None if math.isnan(auc) else auc)
