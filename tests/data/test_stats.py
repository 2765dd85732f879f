import pytest

from grace.data.stats import dataset_stats, size_stats
from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly


def _sample(n_parts: int, rule, **info) -> LabelledAssembly:
    parts = tuple(
        Part(f"p{i}", PartType.PROFILE_200, planar_pose(100 * i, 0)) for i in range(n_parts)
    )
    return LabelledAssembly(Assembly(parts), GroundTruth.explore(n_parts, rule), info)


FREE = lambda state, part: True  # noqa: E731  3! = 6 orders
CHAIN = lambda state, part: part == 0 or bool(state >> (part - 1) & 1)  # noqa: E731  1 order
NEVER_LAST = lambda state, part: part != 2  # noqa: E731  infeasible


def test_size_stats_known_values():
    samples = [
        _sample(3, FREE, robot_pruned=False, nonlocal_block=False, decisive_rules=[]),
        _sample(3, CHAIN, robot_pruned=True, nonlocal_block=True, decisive_rules=["fingers"]),
        _sample(3, CHAIN, robot_pruned=True, nonlocal_block=False, decisive_rules=["joints"]),
        _sample(3, NEVER_LAST, cause="collision", mechanisms=["narrow_rails", "clamp"]),
        _sample(3, NEVER_LAST, cause="reach", mechanisms=["reach"], decisive_rules=["reach"]),
        _sample(3, NEVER_LAST, cause="collision", mechanisms=["narrow_rails"]),
        _sample(3, NEVER_LAST, cause="collision", mechanisms=["compound"]),
    ]
    s = size_stats(samples)
    assert s["assemblies"] == 7
    assert s["infeasible_fraction"] == pytest.approx(4 / 7)
    assert s["orders_mean"] == pytest.approx(8 / 3) and s["orders_median"] == 1.0
    assert s["multi_order_fraction"] == pytest.approx(1 / 3)
    assert s["infeasible_causes"] == {"reach": 0.25, "collision": 0.75, "other": 0.0}
    mechanisms = s["infeasible_mechanisms"]
    assert mechanisms["narrow_rails"] == 0.5 and mechanisms["clamp"] == 0.25
    assert mechanisms["reach"] == 0.25 and mechanisms["compound"] == 0.25
    assert mechanisms["frame_closing"] == 0.0
    decisive = s["rule_decisive_fraction"]
    assert decisive["fingers"] == pytest.approx(1 / 7) and decisive["reach"] == pytest.approx(1 / 7)
    assert decisive["palm"] == 0.0 and set(decisive) >= {"fixation", "arm_links", "clamps"}
    assert s["robot_pruned_fraction"] == pytest.approx(2 / 3)
    assert s["nonlocal_block_fraction"] == pytest.approx(1 / 3)
    # reachable states: free all 8; chain ∅, {0}, {0,1}, {0,1,2}; never-last ∅, {0}, {1}, {0,1}.
    # checks = unplaced parts summed over them: free 3 + 3·2 + 3·1 = 12; chain 3 + 2 + 1 = 6;
    # never-last 3 + 2 + 2 + 1 = 8
    assert s["states"] == 8 + 2 * 4 + 4 * 4
    assert s["checks"] == 12 + 2 * 6 + 4 * 8
    # brute force, step by step until the first failure: free 3·3! = 18; chain 6 + 2 + 1 = 9;
    # part 2 never placeable: 6 + 2 + 2 + 2·1 = 12
    assert s["naive_checks"] == 18 + 2 * 9 + 4 * 12
    # the same parts and ground truth (the info is no part of an assembly): the second chain and
    # the last three never-last ones repeat an earlier assembly
    assert s["exact_copies"] == s["renumbered_copies"] == 1 + 3


def test_undefined_fractions_are_null_and_sizes_are_string_keys():
    stats = dataset_stats(
        [_sample(4, FREE), _sample(3, NEVER_LAST, cause="other")], {3: 0.5, 4: 0.25}, "/d"
    )
    assert list(stats["per_size"]) == ["3", "4"]
    assert stats["per_size"]["3"]["orders_mean"] is None
    assert stats["per_size"]["3"]["robot_pruned_fraction"] is None
    assert stats["per_size"]["4"]["infeasible_causes"] == {
        "reach": None,
        "collision": None,
        "other": None,
    }
    assert stats["per_size"]["4"]["orders_mean"] == 24.0
    assert stats["seconds_per_assembly"] == {"3": 0.5, "4": 0.25}
    assert stats["dataset_path"] == "/d"


def test_simulator_comparison_counts_changed_labels_and_gained_feasibility():
    from grace.data.stats import simulator_comparison

    dual = [_sample(3, FREE), _sample(3, CHAIN), _sample(3, CHAIN)]
    single = [_sample(3, CHAIN), _sample(3, NEVER_LAST), _sample(3, CHAIN)]
    boxes = [_sample(3, FREE), _sample(3, FREE), _sample(3, CHAIN)]
    out = simulator_comparison({"dual_arm": dual, "single_arm": single, "boxes": boxes})["3"]
    assert out["assemblies"] == 3
    assert out["infeasible_fraction"] == {"dual_arm": 0.0, "single_arm": 1 / 3, "boxes": 0.0}
    assert out["labels_changed_vs_boxes"] == pytest.approx(1 / 3)
    assert out["labels_changed_vs_single_arm"] == pytest.approx(2 / 3)
    assert out["feasible_only_with_two_arms"] == pytest.approx(1 / 3)
