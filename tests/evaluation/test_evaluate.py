import numpy as np
import pytest

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.evaluation.baselines import constant_scorer, never_scorer, random_scorer
from grace.evaluation.evaluate import evaluate_assembly, evaluate_by_size


def _sample(n: int, can_place) -> LabelledAssembly:
    parts = tuple(Part(f"p{i}", PartType.PROFILE_200, planar_pose(60.0 * i, 0)) for i in range(n))
    return LabelledAssembly(Assembly(parts), GroundTruth.explore(n, can_place))


# 3 parts, part 2 only last: orders (0,1,2) and (1,0,2)
CHAIN = _sample(3, lambda s, p: p != 2 or s == 0b011)
# 2 parts that block each other: infeasible
STUCK = _sample(2, lambda s, p: False)


def oracle(sample, wrong_first: float = 0.0):
    """Scores 1 for valid next parts, 0 otherwise, and part 2 first at `wrong_first`; off the
    ground truth every unplaced part scores 1."""
    truth = sample.truth
    labels = dict(zip(truth.states.tolist(), truth.completable.tolist(), strict=True))

    def scorer(assembly, states):
        masks = [labels.get(int(s), 0b111 & ~int(s)) for s in states]
        out = np.array([[m >> p & 1 for p in range(3)] for m in masks], float)
        out[states == 0, 2] = wrong_first
        return out

    return scorer


def test_oracle_is_perfect():
    result = evaluate_assembly(oracle(CHAIN), CHAIN)
    assert result.relevant == 2 and result.feasible
    assert result.retrieved[1:].tolist() == [2] * 99  # λ > 0: exactly the truth
    assert result.retrieved[0] == 6 and result.hits[0] == 2  # λ = 0: every order
    assert result.topk_relevant == [True, True]
    assert result.feasibility_scores == {"sequences": 2, "best_sequence": 1.0, "bottleneck": 1.0}
    assert result.passes == 7
    summary = evaluate_by_size(oracle(CHAIN), [CHAIN, CHAIN])[3]
    assert summary["step_auc"] == summary["seq_auc"] == pytest.approx(1.0)
    assert summary["p_at_k"]["2"] == {"value": 1.0, "assemblies": 2, "empty": 0}
    assert np.isnan(summary["p_at_k"]["3"]["value"])


def test_confident_wrong_first_step_costs_precision_at_one():
    # part 2 first scores 0.6 ≥ 0.5: (2, ·, ·) orders are retrieved with probability 0.6 < 1, so
    # P@1 stays 1, but above λ = 0.6 precision is 1 and below it 2 of 4 retrieved are right.
    result = evaluate_assembly(oracle(CHAIN, wrong_first=0.6), CHAIN)
    assert result.retrieved[60] == 4 and result.retrieved[61] == 2
    assert result.hits[60] == 2
    assert result.topk_relevant == [True, True, False]


def test_infeasible_assembly_feeds_only_feasibility_and_step_auc():
    summary = evaluate_by_size(random_scorer(0), [STUCK, CHAIN])
    entry = summary[2]  # only the infeasible one has size 2
    assert np.isnan(entry["seq_auc"]) and np.isnan(entry["step_auc"])
    assert entry["feasibility"]["confusion"]["tp"] == 0
    assert entry["no_sequence"] == 0


def test_random_baseline_is_seeded_and_never_replaces_parts():
    states = np.array([0, 0b101, 0b111 ^ 0b100])
    a = random_scorer(3)(CHAIN.assembly, states)
    assert np.array_equal(a, random_scorer(3)(CHAIN.assembly, states))
    assert a[1, 0] == a[1, 2] == 0.0 and a[2, 0] == a[2, 1] == 0.0
    assert ((a > 0) == ((states[:, None] >> np.arange(3) & 1) == 0)).all()


# CHAIN's on-path states and labels: {} → 0, 1; {0} → 1; {1} → 0; {0, 1} → 2: 5 of 12 positive.


def test_never_retrieving_policy_sits_on_the_floors():
    summary = evaluate_by_size(never_scorer(0), [CHAIN])[3]
    assert summary["seq_auc"] == pytest.approx(0.5)  # recall 0, precision 1 at every λ
    assert summary["p_at_k"]["1"]["value"] == 1.0  # the paper's empty-retrieval rule
    assert summary["p_at_k_strict"]["1"]["value"] == 0.0
    assert summary["p_at_k_strict"]["1"]["empty"] == 1 and summary["no_sequence"] == 1
    # all scores tie: one PR point (recall 1, precision 5/12) closed at (0, 1)
    assert summary["step_auc"] == pytest.approx((1 + 5 / 12) / 2)
    # scoring the step-AUC states must not leak the truth into its feasibility scores
    blocked = _sample(3, lambda s, p: s.bit_count() < 2)  # no third part ever fits: infeasible
    schemes = evaluate_by_size(never_scorer(0), [CHAIN, blocked])[3]["feasibility"]["schemes"]
    assert {name: s["roc_auc"] for name, s in schemes.items()} == {
        "sequences": 0.5,
        "best_sequence": 0.5,
        "bottleneck": 0.5,
    }


def test_constant_policy_retrieves_everything_at_or_below_one_half():
    summary = evaluate_by_size(constant_scorer(0), [CHAIN])[3]
    # λ ≤ 0.5 retrieves all 6 orders (precision 1/3, recall 1), above nothing: (1 + 1/3) / 2
    assert summary["seq_auc"] == pytest.approx(2 / 3)
    # placed parts 0, unplaced 0.5: precision 5/8 at full recall, closed at (0, 1)
    assert summary["step_auc"] == pytest.approx((1 + 5 / 8) / 2)


def test_constant_policy_ranks_a_random_order_first():
    # All 6 orders tie; 2 are true. In part-number order the first would always be (0, 1, 2),
    # a true order (P@1 = 1); a seeded random tie-break ranks each order first as often.
    firsts = [
        evaluate_by_size(constant_scorer(0), [CHAIN], seed=seed)[3]["p_at_k_strict"]["1"]["value"]
        for seed in range(300)
    ]
    assert np.mean(firsts) == pytest.approx(1 / 3, abs=0.06)
    runs = [evaluate_by_size(constant_scorer(0), [CHAIN], seed=7)[3] for _ in range(2)]
    assert [r["p_at_k_strict"]["2"] for r in runs] == [runs[0]["p_at_k_strict"]["2"]] * 2


def test_constant_policy_top_k_is_lexicographic_without_expanding_every_prefix():
    # 9 parts, every order equally probable under the constant policy: ties go lexicographically,
    # (0, …, 6, 7, 8), then (0, …, 6, 8, 7), then (0, …, 5, 7, 6, 8); only part 8 last is valid.
    # Plain best-first search would expand all 623,530 shorter prefixes before the first complete
    # one; the bounded (A*) search walks straight to them.
    n = 9
    last_part_last = _sample(n, lambda s, p: p != n - 1 or s == (1 << (n - 1)) - 1)
    result = evaluate_assembly(constant_scorer(0), last_part_last, k_max=3)
    assert result.topk_relevant == [True, False, True]
    first_part_last = _sample(n, lambda s, p: p != 0 or s == (1 << n) - 2)
    assert evaluate_assembly(constant_scorer(0), first_part_last).topk_relevant == [False] * 3


# One order (1, 0, 2); placing 0 first is feasible but leads to the dead end {0, 2}.
DEAD_END_RULES = {0b000: (0, 1), 0b001: (2,), 0b010: (0,), 0b011: (2,)}
DEAD_END = _sample(3, lambda s, p: p in DEAD_END_RULES.get(s, ()))
DEAD_END_SCORES = {
    0b000: [0.2, 0.9, 0.1],
    0b010: [0.9, 0.0, 0.1],
    0b011: [0.0, 0.0, 0.9],
    0b001: [0.0, 0.2, 0.7],  # off-path: part 2 is feasible here (label 1)
    0b101: [0.0, 0.9, 0.0],  # off-path dead end: part 1 is infeasible (label 0) but scores 0.9
}


def test_step_auc_off_the_true_orders_on_a_hand_case():
    def scorer(assembly, states):
        return np.array([DEAD_END_SCORES.get(int(s), [0.0] * 3) for s in states])

    summary = evaluate_by_size(scorer, [DEAD_END])[3]
    assert summary["step_auc"] == pytest.approx(1.0)  # perfect on the true order
    assert summary["offpath_states"] == 2
    # off-path scores .9 (neg), .7 (pos), .2 and 0s (neg): the PR curve runs (1, 1/2) → (0, 0)
    # → (0, 1), area 1/4
    assert summary["placeable_auc_offpath"] == pytest.approx(0.25)


def test_dead_end_pass_rate_and_leakage_on_a_hand_case():
    def scorer(assembly, states):
        return np.array([DEAD_END_SCORES.get(int(s), [0.0] * 3) for s in states])

    summary = evaluate_by_size(scorer, [DEAD_END])[3]
    # the one feasible step into a dead end from the true order's states: part 0 first, 0.2
    assert summary["dead_end_steps"] == 1 and summary["dead_end_pass_rate"] == 0.0
    # both off-path states go on: {0} through part 2 (0.7), {0, 2} through part 1 (0.9)
    assert summary["dead_end_leakage"] == 1.0
    lifted = {**DEAD_END_SCORES, 0b000: [0.6, 0.9, 0.1], 0b101: [0.0, 0.4, 0.0]}
    summary = evaluate_by_size(
        lambda assembly, states: np.array([lifted.get(int(s), [0.0] * 3) for s in states]),
        [DEAD_END],
    )[3]
    assert summary["dead_end_pass_rate"] == 1.0 and summary["dead_end_leakage"] == 0.5
    # an infeasible assembly has no true order, so no dead-end step counted; its states leak
    stuck = evaluate_by_size(constant_scorer(0), [STUCK])[2]
    assert stuck["dead_end_steps"] == 0 and np.isnan(stuck["dead_end_pass_rate"])
    assert stuck["dead_end_leakage"] == 1.0


def test_floors_of_the_dead_end_rates_and_the_strict_sequence_auc():
    never = evaluate_by_size(never_scorer(0), [CHAIN, DEAD_END])[3]
    assert never["dead_end_pass_rate"] == never["dead_end_leakage"] == 0.0
    assert never["seq_auc_strict"] == 0.0 and never["seq_auc"] == pytest.approx(0.5)
    constant = evaluate_by_size(constant_scorer(0), [CHAIN, DEAD_END])[3]
    assert constant["dead_end_pass_rate"] == constant["dead_end_leakage"] == 1.0
    # λ ≤ 0.5 retrieves all 6 orders of each (precision 1/3 and 1/6, recall 1), above nothing:
    # the strict curve runs (0, 1) → (0, 0) → (1, 1/4) → (1, 0), area 1/8
    assert constant["seq_auc_strict"] == pytest.approx((1 / 3 + 1 / 6) / 2 / 2)
    assert constant["seq_auc"] == pytest.approx((1 + (1 / 3 + 1 / 6) / 2) / 2)


def test_failures_of_feasible_and_infeasible_assemblies_are_kept_apart():
    blocked = _sample(3, lambda s, p: s.bit_count() < 2)  # infeasible
    failures = evaluate_by_size(constant_scorer(0), [CHAIN, blocked])[3]["failures"]
    # CHAIN: all 6 orders retrieved at λ = 0.5; (2, 0, 1) and (2, 1, 0) go wrong at step 1,
    # (0, 2, 1) and (1, 2, 0) at step 2 (from two different states)
    feasible = failures["feasible"]["by_step"]
    assert {k: (v["sequences"], v["false_steps"]) for k, v in feasible.items()} == {
        "1": (2, 1),
        "2": (2, 2),
    }
    # every sequence of the infeasible one is wrong from its first step
    infeasible = failures["infeasible"]["by_step"]
    assert {k: (v["sequences"], v["false_steps"]) for k, v in infeasible.items()} == {"1": (6, 3)}
