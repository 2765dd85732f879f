import numpy as np
import pytest

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.evaluation.baselines import constant_scorer
from grace.evaluation.collapse import fold_health, onpath_step_auc, training_curve

PARTS = tuple(Part(f"p{i}", PartType.PROFILE_200, planar_pose(60.0 * i, 0)) for i in range(3))
# orders (0, 1, 2) and (1, 0, 2): 5 of the 12 on-path labels positive
CHAIN = LabelledAssembly(Assembly(PARTS), GroundTruth.explore(3, lambda s, p: p != 2 or s == 3))


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
    assert onpath_step_auc(constant_scorer(0), [CHAIN]) == pytest.approx((1 + 5 / 8) / 2)


def test_healthy_fold(tmp_path):
    log_dir = _log(tmp_path, [0.5, 0.3, 0.2], [0.4, 0.8, 0.95])
    health = fold_health(_metrics(0.97), [CHAIN], log_dir)
    assert not health["collapsed"] and health["reasons"] == []
    assert health["sizes"] == {"5": {"step_auc": 0.97, "floor": 0.62}}
    assert health["training"]["epochs"] == 3 and health["training"]["val_step_auc_best"] == 0.95
    assert training_curve(log_dir)["train_loss_min"] == 0.2


def test_collapse_at_test_time_in_validation_and_in_training_loss(tmp_path):
    log_dir = _log(tmp_path, [0.5, 0.52, 0.5], [0.33, 0.33, 0.33])
    health = fold_health(_metrics(0.6), [CHAIN], log_dir)
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
    health = fold_health(_metrics(np.float64(0.9)), [CHAIN], tmp_path / "nowhere")
    assert health["training"] == "no training log found" and not health["collapsed"]
