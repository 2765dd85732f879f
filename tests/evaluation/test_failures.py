from collections import Counter

import numpy as np
import pytest

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.orders import GroundTruth
from grace.evaluation.failures import (
    FalseStep,
    failure_histogram,
    failures_report,
    first_false_steps,
    merge_histograms,
)
from grace.planning.sequences import plan, score_states


def line_assembly(n):
    return Assembly(
        tuple(Part(f"p{i}", PartType.PROFILE_200, planar_pose(60.0 * i, 0.0)) for i in range(n))
    )


def table_scorer(n, seed):
    """Fixed random scores per state, in steps of 0.1 (so scores tie with λ)."""
    table = np.random.default_rng(seed).integers(0, 11, size=(1 << n, n)) / 10
    return lambda assembly, states: table[np.asarray(states)]


def _step(step, score, sequences):
    return FalseStep(state=0, part=0, step=step, score=score, sequences=sequences)


def _brute_force(scored, truth, lam):
    """First false steps by listing every retrieved sequence and walking it against the set of
    prefixes of the listed ground-truth orders."""
    prefixes = {order[:i] for order in truth.orders() for i in range(len(order) + 1)}
    found = Counter()
    listed = plan(scored, lam)
    for seq, steps in zip(listed.sequences.tolist(), listed.step_scores, strict=True):
        seq = tuple(seq)
        if seq in prefixes:
            continue
        i = next(i for i in range(len(seq)) if seq[: i + 1] not in prefixes)
        state = sum(1 << p for p in seq[:i])
        found[(state, seq[i], i + 1, float(steps[i]))] += 1
    return found


@pytest.mark.parametrize("n,seed,lam", [(3, 0, 0.3), (4, 1, 0.5), (5, 2, 0.4), (5, 3, 0.6)])
def test_first_false_steps_equal_listing_every_wrong_sequence(n, seed, lam):
    rng = np.random.default_rng(seed)
    table = rng.random((1 << n, n)) < 0.7
    truth = GroundTruth.explore(n, lambda s, p: bool(table[s, p]))
    scored = score_states(table_scorer(n, seed), line_assembly(n))
    got = first_false_steps(scored, truth, lam)
    assert got  # the random policy goes wrong somewhere
    assert Counter({(f.state, f.part, f.step, f.score): f.sequences for f in got}) == _brute_force(
        scored, truth, lam
    )


def test_hand_case_confident_wrong_first_step():
    # Orders (0, 1, 2) and (1, 0, 2). The policy scores the true next parts 1, part 2 first 0.6,
    # and every part 1 off the truth: (2, 0, 1) and (2, 1, 0) are retrieved, both wrong at step 1.
    truth = GroundTruth.explore(3, lambda s, p: p != 2 or s == 0b011)
    labels = dict(zip(truth.states.tolist(), truth.completable.tolist(), strict=True))

    def scorer(assembly, states):
        masks = [labels.get(int(s), 0b111 & ~int(s)) for s in states]
        out = np.array([[m >> p & 1 for p in range(3)] for m in masks], float)
        out[states == 0, 2] = 0.6
        return out

    steps = first_false_steps(score_states(scorer, line_assembly(3)), truth, 0.5)
    assert [(f.state, f.part, f.step, f.score, f.sequences) for f in steps] == [(0, 2, 1, 0.6, 2)]
    hist = failure_histogram(steps, 0.5)
    assert hist["bins"][0] == 0.5 and hist["bins"][-1] == 1.0
    entry = hist["by_step"]["1"]
    assert entry["sequences"] == 2 and entry["false_steps"] == 1
    assert entry["mean_score"] == pytest.approx(0.6)
    assert entry["sequences_by_score"] == [0, 0, 2, 0, 0, 0, 0, 0, 0, 0]  # 0.6 in [0.6, 0.65)


def test_merged_histograms_sum_counts_and_reweight_mean_scores():
    a = failure_histogram([_step(1, 0.9, 3), _step(2, 0.52, 1)], 0.5)
    b = failure_histogram([_step(1, 0.7, 1)], 0.5)
    merged = merge_histograms([a, b])
    assert merged["by_step"]["1"]["sequences"] == 4
    assert merged["by_step"]["1"]["mean_score"] == pytest.approx((3 * 0.9 + 0.7) / 4)
    assert merged["by_step"]["2"]["steps_by_score"][0] == 1
    empty = failure_histogram([], 0.5)
    report = failures_report(
        [
            {5: {"failures": {"feasible": a, "infeasible": empty}}},
            {5: {"failures": {"feasible": b, "infeasible": b}}},
        ]
    )
    assert report["per_size"]["5"]["feasible"]["wrong_sequences"] == 5
    assert report["per_size"]["5"]["infeasible"]["wrong_sequences"] == 1
