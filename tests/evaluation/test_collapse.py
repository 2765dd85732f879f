import numpy as np
import pytest
import torch

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.evaluation.baselines import constant_scorer
from grace.evaluation.collapse import fold_health, state_step_auc, training_curve
from grace.graphs.datamodule import StateDataModule, StateSet
from grace.graphs.encoding import GraphEncoding
from grace.model.module import step_auc as logged_step_auc

PARTS = tuple(Part(f"p{i}", PartType.PROFILE_200, planar_pose(60.0 * i, 0)) for i in range(3))
# orders (0, 1, 2) and (1, 0, 2): 5 of the 12 on-path labels positive
CHAIN = LabelledAssembly(Assembly(PARTS), GroundTruth.explore(3, lambda s, p: p != 2 or s == 3))
# the same orders, and a dead end: part 2 also fits after part 0 alone ({0, 2}: part 1 blocked)
FORK = LabelledAssembly(
    Assembly(PARTS),
    GroundTruth.explore(3, lambda s, p: (p != 2 or s in (1, 3)) and not (p == 1 and s & 4)),
)


def _metrics(grace_auc):
    return {
        "GRACE": {5: {"step_auc": grace_auc}},
        "constant": {5: {"step_auc": 0.62}},
        "never": {5: {"step_auc": 0.55}},
        "random": {5: {"step_auc": 0.58}},
    }


def _log(tmp_path, train_losses, val_aucs, version=0, start=0):
    folder = tmp_path / "logs" / f"version_{version}"
    folder.mkdir(parents=True)
    rows = ["epoch,step,train_loss,train_step_auc,val_loss,val_step_auc"]
    for epoch, (loss, auc) in enumerate(zip(train_losses, val_aucs, strict=True), start):
        rows.append(f"{epoch},{epoch},,,{loss + 0.01},{auc}")  # Lightning writes val and
        rows.append(f"{epoch},{epoch},{loss},0.5,,")  # train metrics on separate rows
    (folder / "metrics.csv").write_text("\n".join(rows) + "\n")
    return tmp_path / "logs"


def test_constant_scorer_validation_floor_is_the_tied_pr_area():
    # unplaced parts tie at 0.5, placed ones score 0: precision 5/8 at full recall
    assert state_step_auc(constant_scorer(0), [CHAIN]) == pytest.approx((1 + 5 / 8) / 2)


def test_the_validation_floor_reads_the_states_training_validates_on(tmp_path):
    # the reachable states add the dead end {0, 2} (one unplaced part, no valid one): 5 of 9
    reachable = state_step_auc(constant_scorer(0), [FORK], StateSet.reachable)
    assert reachable == pytest.approx((1 + 5 / 9) / 2)
    assert state_step_auc(constant_scorer(0), [FORK]) == pytest.approx((1 + 5 / 8) / 2)
    # the AUC a training run logs, of the constant scores over its validation batches (graded
    # dead-end targets among the labels), is that floor
    data = StateDataModule([FORK], [FORK], GraphEncoding(), dead_end_target=0.4)
    scores, labels = [], []
    for batch in data.val_dataloader():
        scores.append((0.5 * (1 - batch.flags))[batch.mask])
        labels.append(batch.labels[batch.mask])
    assert labels[0].max() == 1.0 and (labels[0] == 0.4).any()
    logged = logged_step_auc(torch.cat(scores), torch.cat(labels))
    assert float(logged) == pytest.approx(reachable)
    # a validation AUC of 0.78 beats the reachable states' floor 0.778 but not the on-path 0.812
    log_dir = _log(tmp_path, [0.5, 0.3], [0.77, 0.78])
    assert fold_health(_metrics(0.97), [FORK], log_dir, StateSet.reachable)["collapsed"] is False
    assert fold_health(_metrics(0.97), [FORK], log_dir, StateSet.orders)["reasons"] == [
        "best validation step AUC 0.780 ≤ constant scorer 0.812"
    ]


def test_healthy_fold(tmp_path):
    log_dir = _log(tmp_path, [0.5, 0.3, 0.2], [0.4, 0.8, 0.95])
    health = fold_health(_metrics(0.97), [CHAIN], log_dir, StateSet.orders)
    assert not health["collapsed"] and health["reasons"] == []
    assert health["sizes"] == {"5": {"step_auc": 0.97, "floor": 0.62}}
    assert health["training"]["epochs"] == 3 and health["training"]["val_step_auc_best"] == 0.95
    assert training_curve(log_dir)["train_loss_min"] == 0.2


def test_collapse_at_test_time_in_validation_and_in_training_loss(tmp_path):
    log_dir = _log(tmp_path, [0.5, 0.52, 0.5], [0.33, 0.33, 0.33])
    health = fold_health(_metrics(0.6), [CHAIN], log_dir, StateSet.orders)
    assert health["collapsed"]
    assert health["reasons"] == [
        "A5 test step AUC 0.600 ≤ floor 0.620",
        "best validation step AUC 0.330 ≤ constant scorer 0.812",
        "training loss never fell below its first epoch's",
    ]


def test_a_resumed_fit_s_logs_read_as_one_uninterrupted_history(tmp_path):
    """Killed during epoch 3 (its rows logged, its checkpoint not written), resumed at epoch 3 in
    version_1; then rerun from scratch in version_10 (sorted by number, not as text)."""
    _log(tmp_path, [0.9, 0.5, 0.6, 0.7], [0.4, 0.5, 0.6, 0.7])
    log_dir = _log(tmp_path, [0.3, 0.2], [0.9, 0.8], version=1, start=3)
    assert training_curve(log_dir) == {
        "epochs": 5,
        "train_loss_first": 0.9,
        "train_loss_min": 0.2,
        "val_step_auc_best": 0.9,
    }
    _log(tmp_path, [0.8], [0.1], version=10)
    assert training_curve(log_dir)["epochs"] == 1


def test_missing_training_log_is_said(tmp_path):
    health = fold_health(
        _metrics(np.float64(0.9)), [CHAIN], tmp_path / "nowhere", StateSet.reachable
    )
    assert health["training"] == "no training log found" and not health["collapsed"]
