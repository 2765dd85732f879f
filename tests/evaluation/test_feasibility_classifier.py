import math

import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import OmegaConf

from grace.evaluation.feasibility_classifier import classifier_roc_auc, pooled_embeddings


def make_module(cfg):
    return instantiate(cfg.model)


@pytest.fixture
def labelled(fake_simulator):
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(3)
    drawn = [simulator.sample(n, rng) for n in (4, 5) * 20]
    feasible = [s for s in drawn if s.truth.feasible]
    infeasible = [s for s in drawn if not s.truth.feasible]
    assert len(feasible) >= 4 and len(infeasible) >= 4
    return feasible[:8] + infeasible[:8]


@pytest.mark.parametrize("name", ["svm_linear", "svm_rbf", "mlp", "knn"])
def test_classifier_configs_score_every_test_size(cfg_factory, labelled, name):
    cfg = cfg_factory(f"classifier={name}")
    roc = classifier_roc_auc(
        instantiate(cfg.classifier.estimator), make_module(cfg), labelled, labelled
    )
    assert set(roc) == {s.size for s in labelled}
    assert all(math.isnan(v) or 0.0 <= v <= 1.0 for v in roc.values())


def test_one_nearest_neighbour_recalls_its_training_set(cfg_factory, labelled):
    cfg = cfg_factory("classifier=knn", "classifier.estimator._args_.1.n_neighbors=1")
    module = make_module(cfg)
    assert pooled_embeddings(module, labelled).shape == (len(labelled), 94)
    roc = classifier_roc_auc(instantiate(cfg.classifier.estimator), module, labelled, labelled)
    defined = [v for v in roc.values() if not math.isnan(v)]
    assert defined and all(v == 1.0 for v in defined)


def test_one_class_training_set_gives_undefined_auc(cfg_factory, labelled):
    cfg = cfg_factory("classifier=svm_linear")
    feasible_only = [s for s in labelled if s.truth.feasible]
    roc = classifier_roc_auc(
        instantiate(cfg.classifier.estimator), make_module(cfg), feasible_only, labelled
    )
    assert all(math.isnan(v) for v in roc.values())


def test_no_classifier_by_default(cfg_factory):
    assert OmegaConf.select(cfg_factory(), "classifier.estimator") is None
