import math

import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import OmegaConf
from sklearn.metrics import roc_auc_score
from sklearn.mixture import GaussianMixture

from grace.evaluation.density import FlowDensity
from grace.evaluation.feasibility_classifier import pooled_embeddings
from grace.evaluation.feasibility_schemes import (
    MIN_DENSITY_FIT,
    add_schemes,
    embedding_schemes,
    feasibility_report,
    scheme_summary,
)

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)


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


@pytest.mark.parametrize(
    "name",
    [
        "svm_linear",
        "mlp",
        # the two slowest configs (about 8 s each here) run under -m slow
        pytest.param("svm_rbf", marks=pytest.mark.slow),
        pytest.param("knn", marks=pytest.mark.slow),
    ],
)
def test_classifier_configs_score_every_test_size(cfg_factory, labelled, name):
    cfg = cfg_factory(f"classifier={name}")
    classifiers = {name: instantiate(cfg.classifier.estimator)}
    schemes = embedding_schemes(make_module(cfg), labelled, labelled, classifiers)
    assert set(schemes) == {f"classifier: {name}"}
    per_size = schemes[f"classifier: {name}"]
    assert set(per_size) == {s.size for s in labelled}
    for size, summary in per_size.items():
        feasible = [s.truth.feasible for s in labelled if s.size == size]
        assert summary["assemblies"] == len(feasible) and summary["feasible"] == sum(feasible)


def test_one_nearest_neighbour_recalls_its_training_set(cfg_factory, labelled):
    cfg = cfg_factory("classifier=knn", "classifier.estimator._args_.1.n_neighbors=1")
    module = make_module(cfg)
    assert pooled_embeddings(module, labelled).shape == (len(labelled), 94)
    knn = {"knn": instantiate(cfg.classifier.estimator)}
    per_size = embedding_schemes(module, labelled, labelled, knn)["classifier: knn"]
    defined = [v["roc_auc"] for v in per_size.values() if not math.isnan(v["roc_auc"])]
    assert defined and all(v == 1.0 for v in defined)


def test_one_class_training_set_skips_classifiers_but_not_densities(
    cfg_factory, fake_simulator, labelled
):
    cfg = cfg_factory("classifier=svm_linear")
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(5)
    drawn = [simulator.sample(n, rng) for n in (4, 5) * 60]
    feasible_only = [s for s in drawn if s.truth.feasible][:MIN_DENSITY_FIT]
    assert len(feasible_only) == MIN_DENSITY_FIT
    module = make_module(cfg)
    svm = {"svm": instantiate(cfg.classifier.estimator)}
    flow = {"flow": FlowDensity(epochs=5)}
    schemes = embedding_schemes(module, feasible_only, labelled, svm, flow)
    assert set(schemes) == {"density: flow"}
    # one feasible assembly fewer: no density either (too few points for its features)
    assert embedding_schemes(module, feasible_only[1:], labelled, svm, flow) == {}


def test_no_classifier_by_default(cfg_factory):
    assert OmegaConf.select(cfg_factory(), "classifier.estimator") is None


@pytest.mark.slow  # end to end; its parts have fast tests of their own
def test_flow_scores_held_out_feasible_above_a_shifted_set():
    # Synthetic "embeddings": feasible ones on a curved 2-d manifold in 6-d with noise; the
    # shifted set leaves the manifold by a small offset that no single coordinate reveals.
    rng = np.random.default_rng(0)

    def on_manifold(n):
        t = rng.uniform(-2, 2, size=n)
        base = np.stack([t, t**2, np.sin(2 * t), t * 0.5, -t, np.cos(t)], axis=1)
        return base + 0.05 * rng.normal(size=base.shape)

    train, held_out = on_manifold(300), on_manifold(100)
    shifted = on_manifold(100) + np.array([0.0, -0.4, 0.3, 0.0, 0.0, 0.0])
    flow = FlowDensity(hidden=(32, 32), epochs=300, seed=0).fit(train)
    scores = flow.score_samples(np.concatenate([held_out, shifted]))
    labels = np.array([True] * len(held_out) + [False] * len(shifted))
    assert roc_auc_score(labels, scores) > 0.95
    # a single Gaussian, the density without the flow's shape, separates them far less well
    gaussian = GaussianMixture(1, covariance_type="full", random_state=0).fit(train)
    assert roc_auc_score(labels, gaussian.score_samples(np.concatenate([held_out, shifted]))) < 0.9
    again = FlowDensity(hidden=(32, 32), epochs=300, seed=0).fit(train).score_samples(held_out)
    assert np.array_equal(again, scores[: len(held_out)])  # seeded: the same fit


def test_scheme_summary_and_report_average_folds():
    feasible = [True, True, False, False]
    perfect = scheme_summary(feasible, [0.9, 0.8, 0.2, 0.1])
    inverted = scheme_summary(feasible, [0.1, 0.2, 0.8, 0.9])
    assert perfect["roc_auc"] == 1.0 and perfect["tpr_at_fpr"] == 1.0
    assert inverted["roc_auc"] == 0.0 and inverted["tpr_at_fpr"] == 0.0
    assert math.isnan(scheme_summary([True, True], [0.1, 0.2])["roc_auc"])
    folds = [{}, {}]
    add_schemes(folds[0], {"best_sequence": {5: perfect}})
    add_schemes(folds[1], {"best_sequence": {5: inverted}})
    entry = feasibility_report(folds)["per_size"]["5"]["best_sequence"]
    assert entry["roc_auc"] == {"mean": 0.5, "std": 0.5}
    assert entry["folds"] == 2 and entry["assemblies"] == 8 and entry["feasible"] == 4
    # vertical average: the perfect curve is 1 everywhere, the inverted one 0 until FPR 1
    assert entry["roc"]["tpr"][0] == 0.5 and entry["roc"]["tpr"][-1] == 1.0
