"""task=size_diagnosis: held-out assemblies only, score groups as the step labels say, hooks that
measure and then leave the network as it was."""

import json

import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import open_dict

from grace.cli.folds import protocol_folds
from grace.errors import UserError
from grace.evaluation.activation_scale import ActivationProbe, activation_scale
from grace.evaluation.size_scores import held_out, step_scores
from grace.evaluation.step_states import label_matrix, onpath_states
from grace.tasks.experiment import run as experiment
from grace.tasks.size_diagnosis import run as diagnose

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)

SIZES = "dataset.sizes={3: 6, 4: 6, 5: 6, 8: 4}"


def _cfg(cfg_factory, fake_simulator, *overrides):
    cfg = cfg_factory(
        SIZES, "protocol.folds=2", "threads=1", "trainer.max_epochs=1",
        "trainer.enable_progress_bar=false", "model.net.hidden=8", *overrides,
    )  # fmt: skip
    with open_dict(cfg):
        cfg.simulator = fake_simulator
    return cfg


def test_held_out_assemblies_never_train_the_fold(cfg_factory, fake_simulator):
    cfg = _cfg(cfg_factory, fake_simulator, "protocol=one_to_many", "train_size=4")
    data = instantiate(cfg.dataset).load()
    _, _, folds = protocol_folds(cfg, data)
    for fold in folds:
        unseen = held_out(data, 2, 0, fold.index)
        assert not set(unseen) & set(fold.train + fold.val)
        assert set(fold.test) <= set(unseen)  # the fold's test assemblies are held out too
        assert {data[i].size for i in unseen} == {3, 4, 5, 8}


def test_score_groups_follow_the_labels(samples):
    sample = samples[1]
    states, masks = onpath_states(sample.truth)
    scorer = lambda assembly, s: label_matrix(masks, sample.size).astype(float)  # noqa: E731
    groups = step_scores(scorer, [sample])["onpath"]
    placed = label_matrix(states, sample.size)
    assert np.all(groups["valid"] == 1.0) and np.all(groups["invalid"] == 0.0)
    assert groups["valid"].size == label_matrix(masks, sample.size).sum()
    assert groups["valid"].size + groups["invalid"].size == (~placed).sum()


def test_probe_measures_and_removes_its_hooks(cfg_factory, samples):
    module = instantiate(cfg_factory("model=grace_geometric", "model.net.hidden=8").model)
    with ActivationProbe(module.net) as probe:
        assert module.net.fuse._forward_pre_hooks
    assert not module.net.fuse._forward_pre_hooks and not module.net._forward_pre_hooks
    # An infeasible assembly has one state on its true orders: the empty one.
    empty = activation_scale(module, [samples[-1]], states_per_assembly=1)
    assert empty["placed_sum"]["mean"] == 0.0  # nothing is placed in the empty state
    assert empty["unplaced_sum"]["mean"] > 0.0
    more = activation_scale(module, samples[1:3], states_per_assembly=8)
    assert {"part_norm", "surface_norm_0", "part_pe_term", "head_input"} <= set(more)
    assert more["placed_sum"]["count"] > empty["placed_sum"]["count"]
    del probe


def test_size_diagnosis_end_to_end(cfg_factory, fake_simulator, tmp_path):
    run_dir = tmp_path / "run"
    experiment(
        _cfg(cfg_factory, fake_simulator, "protocol=one_to_many", "train_size=4",
             f"paths.output_dir={run_dir}", "model=grace_geometric", "task.fold_jobs=1",
             "task.recording.per_size=0")
    )  # fmt: skip
    out = tmp_path / "diagnosis"
    cfg = _cfg(cfg_factory, fake_simulator, "task=size_diagnosis", f"ckpt={run_dir}",
               f"paths.output_dir={out}", "task.states_per_assembly=4")  # fmt: skip
    diagnose(cfg)
    report = json.loads((out / "size_diagnosis.json").read_text())
    assert report["train_sizes"] == [4] and set(report["scores"]) == {"3", "4", "5", "8"}
    assert report["scores"]["4"]["assemblies"] == 3  # fold 0's half of the six A4 assemblies
    for per_size in report["scores"].values():
        kinds = per_size["onpath"]
        assert kinds["valid"]["count"] + kinds["invalid"]["count"] > 0
    assert (out / "size_diagnosis.png").stat().st_size > 0
    table = (out / "size_diagnosis.md").read_text().splitlines()
    assert table[0] == "|  | A3 | A4 | A5 | A8 | A8 ÷ A4 |"
    assert any(line.startswith("| `placed_sum` |") for line in table)
    wrong = _cfg(cfg_factory, fake_simulator, "task=size_diagnosis", f"ckpt={run_dir}",
                 "dataset.sizes={3: 5, 4: 6, 5: 6, 8: 4}")  # fmt: skip
    with pytest.raises(UserError, match="not the data set of the run"):
        diagnose(wrong)
