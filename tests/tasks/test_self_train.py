"""task=self_train's rounds (grace/tasks/self_train.py) on the fake world of conftest.py: a round
adds only orders whose every step the simulator accepts, the test assemblies' ground truth is
not read before scoring, and no drawn assembly copies a test assembly."""

import json
from pathlib import Path

import numpy as np
import pytest
from grace_tests_conftest import accepted, fake_plan
from hydra.utils import instantiate

from grace.data.unlabelled import UnlabelledDraws, layout_key
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.evaluation.expert_iteration import (
    FIRST_CHOICE,
    brute_force_labeller,
    expert_iteration,
)
from grace.evaluation.self_train import RoundFigures, chosen_round, self_train_markdown
from grace.planning.self_labels import plan_labels
from grace.tasks.self_train import run

SIZES = {4: 6, 5: 6}


class SealedTruth:
    """A test assembly's ground truth that fails the test when read while `sealed`."""

    def __init__(self, truth: GroundTruth) -> None:
        self.__dict__.update(truth=truth, sealed=True)

    def __getattr__(self, name):
        if self.__dict__["sealed"]:
            raise AssertionError(f"the test assemblies' ground truth was read ({name})")
        return getattr(self.__dict__["truth"], name)


def fake_search(simulator):
    """A labeller as task=self_train's, its plan listing every order of the row with the
    simulator's verdicts, refused ones included (conftest.py, fake_plan)."""

    def label(scorer, assembly):
        rules = simulator._rules(assembly, robot=True)
        rng = np.random.default_rng(assembly.n_parts)
        orders = [tuple(rng.permutation(assembly.n_parts).tolist()) for _ in range(40)]
        orders += [tuple(range(assembly.n_parts)), tuple(reversed(range(assembly.n_parts)))]
        return plan_labels(fake_plan(assembly, rules, orders), assembly)

    return label


def run_rounds(simulator, train, test, label, score=None, rounds=2):
    """expert_iteration with a fit that records each round's training set."""
    draws = UnlabelledDraws(simulator, seed=7)
    fits = []

    def fit(samples, r):
        fits.append(list(samples))
        return lambda assembly, states: np.full((len(states), assembly.n_parts), 0.5)

    reports = []
    score = score or (lambda scorer: {})
    rounds_done = expert_iteration(
        rounds, train, lambda r: [d.assembly for d in draws.batch(r, SIZES, test)], fit, label,
        score, reports.append,
    )  # fmt: skip
    return rounds_done, fits, reports


def test_a_round_adds_only_orders_the_simulator_accepts_at_every_step(fake_simulator, samples):
    simulator = instantiate(fake_simulator)
    done, fits, reports = run_rounds(simulator, samples, [], fake_search(simulator))
    assert len(fits) == 3 and fits[0] == samples
    added = fits[-1][len(samples) :]
    assert len(added) == done[-1].added == sum(r.labelled for r in done)
    assert any(s.truth.feasible for s in added)
    for sample in added:
        rules = simulator._rules(sample.assembly, robot=True)
        assert all(accepted(rules, order) for order in sample.truth.orders())
        assert sample.info["labels"] == "verified"
    assert [r.drawn for r in done] == [0, sum(SIZES.values()), sum(SIZES.values())]
    names = [s.assembly.name for s in added]
    assert len(set(names)) == len(names)  # no assembly drawn in two rounds
    assert len(reports) == 4 and "verified share" in self_train_markdown({}, done)


def test_each_round_is_judged_by_its_first_choice_on_the_next_draws(fake_simulator, samples):
    """`RoundFigures.first_choice` of round r is the share of round r + 1's feasible draws
    (one more draw for the last round) whose first choice of round r's model is an order; the
    fit's policy scores every part alike, so its first choice is the identity order."""
    simulator = instantiate(fake_simulator)
    done, _, _ = run_rounds(simulator, samples, [], brute_force_labeller(simulator))
    draws = UnlabelledDraws(simulator, seed=7)
    shares = []
    for r, figures in enumerate(done):
        truths = [simulator.label(d.assembly).truth for d in draws.batch(r + 1, SIZES, [])]
        right = [tuple(range(t.n_parts)) in set(t.orders()) for t in truths if t.feasible]
        shares.append(sum(right) / len(right))
        assert figures.first_choice == pytest.approx(shares[-1])
    assert max(shares) > 0 and min(shares) < 1
    assert "judge" in done[-1].seconds and "judge" not in done[0].seconds
    chosen = f"Chosen round (its first choice on fresh draws right most often): {np.argmax(shares)}"
    assert chosen in self_train_markdown({}, done)


def test_the_first_choice_is_planned_under_the_rule(fake_simulator):
    """The first choice that judges a round is Algorithm 1's under the run's `threshold=` rule:
    a rule that makes the highest unplaced part the only choice turns the constant policy's
    identity order into the reversed one, whatever the policy scored."""

    def last_first(scorer):
        def scores(assembly, states):
            n = assembly.n_parts
            out = np.zeros((len(states), n))
            for row, state in enumerate(states):
                out[row, max(p for p in range(n) if not int(state) >> p & 1)] = 1.0
            return out

        return scores

    simulator = instantiate(fake_simulator)
    constant = lambda assembly, states: np.full((len(states), assembly.n_parts), 0.5)  # noqa: E731
    plain, ruled = brute_force_labeller(simulator), brute_force_labeller(simulator, 0.5, last_first)
    differ = 0
    for draw in UnlabelledDraws(simulator, seed=7).batch(1, SIZES, []):
        truth = simulator.label(draw.assembly).truth
        if not truth.feasible:
            continue
        n = draw.assembly.n_parts
        identity, reverse = (truth.is_order(o) for o in (tuple(range(n)), tuple(range(n))[::-1]))
        assert plain(constant, draw.assembly).info[FIRST_CHOICE] == identity
        assert ruled(constant, draw.assembly).info[FIRST_CHOICE] == reverse
        differ += identity != reverse
    assert differ  # the two orders are told apart on some draw


@pytest.mark.parametrize("patience, trained", [(1, 2), (2, 3), (None, 3)])
def test_the_rounds_stop_once_patience_judged_rounds_were_no_better(
    fake_simulator, samples, patience, trained
):
    """Round 0's model always chooses right on fresh draws, every later one never: with
    patience 1 the rounds stop once round 1 is judged (round 2's draws judge it and train
    nothing); with patience 2 round 2 still trains, and the last round is judged on one more
    draw as without patience."""
    simulator = instantiate(fake_simulator)
    truth_label = brute_force_labeller(simulator)
    draws = UnlabelledDraws(simulator, seed=7)
    fits = []

    def fit(samples, r):
        fits.append(len(samples))
        scorer = lambda assembly, states: np.full((len(states), assembly.n_parts), 0.5)  # noqa: E731
        scorer.right = r == 0
        return scorer

    def label(scorer, assembly):
        sample = truth_label(scorer, assembly)
        if sample.truth.feasible:
            sample.info[FIRST_CHOICE] = scorer.right
        return sample

    reports = []
    done = expert_iteration(
        2, samples, lambda r: [d.assembly for d in draws.batch(r, SIZES, [])], fit, label,
        lambda scorer: {}, reports.append, patience,
    )  # fmt: skip
    assert len(fits) == len(done) == trained
    assert [r.first_choice for r in done] == [1.0] + [0.0] * (trained - 1)
    assert chosen_round([r.first_choice for r in done]) == 0
    assert "judge" in done[-1].seconds and reports[-1] == done
    if patience == 1:  # round 2's draws were labelled, judged round 1, and joined no training
        assert done[-1].added == fits[-1] - len(samples) == done[-1].labelled


def test_the_test_assemblies_truth_is_read_only_to_score(fake_simulator, samples):
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(3)
    sealed = [SealedTruth(simulator.sample(n, rng).truth) for n in (4, 5, 5)]
    test = [
        LabelledAssembly(simulator.generate(n, rng), truth)
        for n, truth in zip((4, 5, 5), sealed, strict=True)
    ]
    scored = []

    def score(scorer):
        for truth in sealed:
            truth.__dict__["sealed"] = False
        scored.append(sum(s.truth.feasible for s in test))
        for truth in sealed:
            truth.__dict__["sealed"] = True
        return {}

    done, _, _ = run_rounds(simulator, samples, test, fake_search(simulator), score)
    assert len(scored) == len(done) == 3


def test_no_drawn_assembly_copies_a_test_assembly(fake_simulator):
    simulator = instantiate(fake_simulator)
    same_stream = UnlabelledDraws(simulator, seed=7)
    # the test set is the first draws of the very stream self-training draws from
    test = [
        LabelledAssembly(d.assembly, SealedTruth(GroundTruth.from_orders(d.size, [])))
        for d in same_stream.first({4: 12}, [])
    ]
    taken = {layout_key(s.assembly) for s in test}
    draws = UnlabelledDraws(simulator, seed=7)
    for r in (1, 2):
        batch = draws.batch(r, {4: 4}, test)
        assert len(batch) == 4
        assert not taken & {layout_key(d.assembly) for d in batch}
        assert min(d.index for d in batch) >= 12  # the first 12 draws are the test's


def test_the_chosen_round_is_the_best_judged_and_the_earlier_on_a_tie():
    judged = [0.4, 0.6, 0.6, 0.5]
    assert chosen_round(judged) == 1
    assert chosen_round([*judged, None]) is None and chosen_round([]) is None


def test_the_round_figures_write_as_json():
    figures = RoundFigures(round=1, drawn=4, verified=3, labelled=4, infeasible=1)
    figures.test = {"8": {"p_at_1_strict": float("nan")}}
    out = figures.to_json()
    assert out["verified_share"] == 0.75 and out["test"]["8"]["p_at_1_strict"] is None


@pytest.mark.slow  # the real simulator, two trainings, a verified search per drawn frame (2 min)
def test_the_task_writes_its_rounds(cfg_factory):
    cfg = cfg_factory(
        "task=self_train", "scale=smoke", "protocol=upward", "protocol.folds=2",
        "protocol.train_sizes=[3,4,5]", "protocol.test_sizes=[6,7]", "trainer.max_epochs=1",
        "task.sizes={6: 2, 7: 2}", "task.rounds=1", "threads=1", "task.probe_checks=20",
        "task.probe_own_sequence=true", "task.patience=1",
    )  # fmt: skip
    value = run(cfg)
    out = json.loads((Path(cfg.paths.output_dir) / "self_train.json").read_text())
    assert out["settings"]["probe_checks"] == 20 and out["settings"]["probe_own_sequence"]
    assert out["settings"]["patience"] == 1
    assert out["settings"]["threshold"]["_target_"].endswith(".LiftedThreshold")  # the default
    kept = out["rounds"][-1 if out["chosen_round"] is None else out["chosen_round"]]["test"]
    assert value == pytest.approx(np.mean([f["p_at_1_strict"] for f in kept.values()]))
    first, second = out["rounds"]
    assert (first["drawn"], second["drawn"]) == (0, 4)
    assert second["added"] == second["labelled"] == second["verified"] + second["infeasible"]
    assert set(second["test"]) == {"6", "7"}
    md = (Path(cfg.paths.output_dir) / "self_train.md").read_text()
    assert md.startswith("# Self-training") and "threshold: LiftedThreshold" in md
