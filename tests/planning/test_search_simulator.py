"""Verified search against the real simulator: its step checks agree with the ground truth and
with `Simulator.explain`, a refused part stays refused in every state holding its blockers
(obstacles only accumulate), and every order it returns replays in the uncached MuJoCo cell."""

import itertools

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.utils import instantiate
from planning_fakes import fixed_scores

from grace import CONF_DIR
from grace.cli.schemas import register_schemas
from grace.domain.assembly import Assembly, Part, PartType, mask_to_parts, planar_pose
from grace.evaluation.baselines import random_scorer
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.fixation_prior import FixationPrior
from grace.planning.search import Direction, Frontier, Outcome, VerifiedSearch
from grace.planning.step_checks import brute_force


def simulator(*overrides: str):
    register_schemas(light=True)  # the simulator group only: no torch-side schemas needed
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(config_name="config", overrides=list(overrides))
    GlobalHydra.instance().clear()
    return instantiate(cfg.simulator)


@pytest.fixture(scope="module")
def sim():
    return simulator()


@pytest.fixture(scope="module")
def generated(sim):
    """Seeded A3–A6 frames with their ground truth, infeasible ones among them."""
    rng = np.random.default_rng(7)
    return [sim.label(sim.generate(n, rng)) for n in (3, 4, 5, 5, 6, 6, 6)]


def profile(length: int, x: float, y: float, along_x: bool = False) -> Part:
    kind = PartType.PROFILE_300 if length == 300 else PartType.PROFILE_200
    return Part(f"p{x:g}_{y:g}", kind, planar_pose(x, y, 1 if along_x else 0))


RAILS = Assembly(
    (profile(300, 0, 0, True), profile(200, -24, 120), profile(200, 24, 120)), name="rails"
)
"""Two stems 8 mm apart: no room for a finger beside whichever comes first."""

DEAD_START = Assembly(
    (
        Part("a", PartType.PROFILE_300, planar_pose(90, -50)),
        Part("b", PartType.PROFILE_200, planar_pose(30, 120, 1)),
        Part("c", PartType.PROFILE_200, planar_pose(-30, -130, 1)),
        Part("d", PartType.PROFILE_300, planar_pose(-150, 0)),
        Part("e", PartType.PROFILE_200, planar_pose(150, 100)),
    ),
    name="dead_start",
)
"""Placing part 3 first is possible, but no order goes on from there."""


@pytest.mark.slow  # every step of generated assemblies in MuJoCo; the hand cases stay fast
def test_step_checks_agree_with_the_ground_truth_and_explain(sim, generated):
    for sample in generated:
        truth, oracle = sample.truth, SimulatorSteps(sim, sample.assembly)
        n = truth.n_parts
        for state, placeable in zip(truth.states.tolist(), truth.placeable.tolist(), strict=True):
            for part in range(n):
                if state >> part & 1:
                    continue
                check = oracle.check(state, part)
                assert check.feasible == bool(placeable >> part & 1)
                assert check.feasible == oracle.checker.verdict(state, part).feasible
                if check.conflicts is None:
                    continue
                # the blockers are placed, and the part stays out of every state meeting them
                assert not check.feasible and check.conflicts
                assert all(c and c & state == c for c in check.conflicts)
                later = (truth.states >> part & 1) == 0
                for conflict in check.conflicts:
                    later &= (truth.states & conflict) != 0
                assert not (truth.placeable[later] >> part & 1).any()
        assert oracle.checks == truth.checks  # every reachable (state, unplaced part) once
        forced = brute_force(SimulatorSteps(sim, sample.assembly))
        assert forced.same_orders(truth) and forced.checks == truth.checks


@pytest.mark.parametrize("direction", list(Direction))
@pytest.mark.parametrize("frontier", list(Frontier))
@pytest.mark.parametrize("learn", [True, False])
def test_exhaustive_search_verifies_exactly_the_ground_truth_orders(
    sim, generated, direction, frontier, learn
):
    assert {s.truth.feasible for s in generated} == {True, False}
    for sample in generated:
        config = VerifiedSearch(k=None, direction=direction, frontier=frontier, learn_blocks=learn)
        oracle = SimulatorSteps(sim, sample.assembly)
        result = config.plan(random_scorer(1), sample.assembly, oracle)
        assert set(result.verified.orders()) == set(sample.truth.orders())
        assert result.verified.same_orders(sample.truth)
        expected = Outcome.verified if sample.truth.feasible else Outcome.infeasible
        assert result.outcome == expected and result.exhausted


def test_with_fixation_switched_off_the_search_drops_no_step_for_it(sim, generated):
    """The prior is read off the checks: in a cell without the fixation rule it refuses
    nothing, and the exhaustive search still finds every order, more than with the rule."""
    free = simulator("simulator.rules.fixation=false")
    gained = 0
    for sample in generated[:6]:
        assembly = sample.assembly
        truth = brute_force(SimulatorSteps(free, assembly))
        result = VerifiedSearch(k=None).plan(
            random_scorer(1), assembly, SimulatorSteps(free, assembly)
        )
        assert result.verified.same_orders(truth)
        gained += truth.n_orders() - sample.truth.n_orders()
    assert gained > 0


def test_a_hand_built_infeasible_frame_is_proved_infeasible(sim):
    assembly = RAILS
    truth = sim.label(assembly).truth
    assert not truth.feasible
    for direction, frontier in itertools.product(Direction, Frontier):
        result = VerifiedSearch(direction=direction, frontier=frontier).search(
            fixed_scores({}, assembly.n_parts), SimulatorSteps(sim, assembly)
        )
        assert result.outcome == Outcome.infeasible and not result.orders
        assert result.checks <= truth.checks


def test_a_model_wrong_at_step_1_still_gets_an_order_the_cell_executes(sim):
    truth = sim.label(DEAD_START).truth
    assert truth.feasible and truth.placeable[0] >> 3 & 1 and not truth.completable[0] >> 3 & 1

    def wrong(assembly, states):  # it loves the dead first step
        rows = np.full((len(states), 5), 0.5)
        rows[np.asarray(states) == 0] = [0.2, 0.1, 0.1, 0.95, 0.1]
        return rows

    for direction, frontier, learn in itertools.product(Direction, Frontier, (True, False)):
        oracle = SimulatorSteps(sim, DEAD_START)
        search = VerifiedSearch(direction=direction, frontier=frontier, learn_blocks=learn)
        result = search.plan(wrong, DEAD_START, oracle)
        assert result.outcome == Outcome.verified
        order = result.orders[0].sequence
        assert order in set(truth.orders()) and order[0] != 3
        assert sim.replay(DEAD_START, order) is None  # the uncached MuJoCo reference
        refused = [e for e in result.events if e.kind == "refused"]
        assert all(oracle.checker.verdict(e.state, e.part).rule for e in refused)
        if direction == Direction.forward:  # it took the dead step and was refused below it
            assert result.events[0].part == 3 and refused


def test_returned_orders_replay_in_the_uncached_cell(sim):
    rng = np.random.default_rng(11)
    for n in (5, 6, 7):
        assembly = sim.generate(n, rng)
        for direction in Direction:
            result = VerifiedSearch(k=3, direction=direction).plan(
                random_scorer(n), assembly, SimulatorSteps(sim, assembly)
            )
            assert result.orders
            for ranked in result.orders:
                assert sim.replay(assembly, ranked.sequence) is None


def test_the_fixation_prior_never_rules_out_a_step_an_order_takes(sim, generated):
    """Every reachable state is buildable and every step the ground truth allows is fixed;
    states outside the ground truth that the prior calls unbuildable are indeed unreached. The
    prior read off the simulator's checks is the geometry's."""
    for sample in generated:
        truth, assembly = sample.truth, sample.assembly
        prior = FixationPrior.of(assembly, sim.tolerance)
        assert FixationPrior.of_steps(SimulatorSteps(sim, assembly)) == prior  # the checks' rule
        reached = set(truth.states.tolist())
        for state, placeable in zip(truth.states.tolist(), truth.placeable.tolist(), strict=True):
            assert prior.buildable(state)
            assert all(prior.allows(state, p) for p in mask_to_parts(placeable))
        unbuildable = [s for s in range(1 << assembly.n_parts) if not prior.buildable(s)]
        assert unbuildable and not reached & set(unbuildable)
        first = [p for p in range(assembly.n_parts) if prior.fixed(0, p)]
        assert first == [p for p in range(assembly.n_parts) if assembly.parts[p].type.is_profile]
