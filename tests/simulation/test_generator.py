import math

import numpy as np
import pytest

from grace.domain.assembly import canonical_order
from grace.simulation.generator import StructureGenerator
from grace.simulation.joints import end_joints, insertion_motions, parts_overlap, touching

FINGER = 12.0


@pytest.fixture(scope="module")
def generator(sim_cfg):
    return StructureGenerator(finger_mm=FINGER, **sim_cfg["generator"])


@pytest.fixture(scope="module")
def batch(generator):
    rng = np.random.default_rng(7)
    return [generator.generate(n, rng) for n in (2, 3, 5, 7, 9, 12) for _ in range(15)]


def _connected(touch: np.ndarray) -> bool:
    seen, todo = {0}, [0]
    while todo:
        for j in np.flatnonzero(touch[todo.pop()]):
            if int(j) not in seen:
                seen.add(int(j))
                todo.append(int(j))
    return len(seen) == len(touch)


def test_same_seed_same_assembly(generator):
    a = generator.generate(7, np.random.default_rng(3))
    b = generator.generate(7, np.random.default_rng(3))
    c = generator.generate(7, np.random.default_rng(4))
    assert a == b and a != c


def test_structures_are_valid_connected_and_canonical(batch, sim_cfg):
    width, depth = sim_cfg["generator"]["work_area"]
    for asm in batch:
        parts = list(asm.parts)
        assert [p.name for p in parts] == [f"part_{i + 1}" for i in range(len(parts))]
        assert canonical_order(parts) == parts
        assert all(np.allclose(p.pose[:2, :2] @ p.pose[:2, :2].T, np.eye(2)) for p in parts)
        assert not any(
            parts_overlap(a, b, 0.5) for i, a in enumerate(parts) for b in parts[i + 1 :]
        )
        assert _connected(touching(asm))
        boxes = np.array([b for p in parts for b in p.footprint_boxes()])
        lo, hi = boxes[:, :2].min(axis=0), boxes[:, 2:].max(axis=0)
        assert np.all(np.abs((lo + hi) / 2) <= 1.0)
        assert hi[0] - lo[0] <= width and hi[1] - lo[1] <= depth


def test_brackets_sit_in_inner_corners_of_two_profiles(batch):
    brackets = 0
    for asm in batch:
        touch = touching(asm)
        joined = {(j.part, j.host) for j in end_joints(asm.parts)}
        for i, p in enumerate(asm.parts):
            if p.type.is_profile:
                continue
            brackets += 1
            profiles = [j for j in np.flatnonzero(touch[i]) if asm.parts[j].type.is_profile]
            assert len(profiles) == 2
            a, b = profiles
            assert (a, b) in joined or (b, a) in joined
    assert brackets > 0


def _rail_gaps(asm) -> list[float]:
    """Gaps between parallel profiles that face each other along a shared stretch."""
    gaps = []
    profiles = [p for p in asm.parts if p.type.is_profile]
    for i, a in enumerate(profiles):
        for b in profiles[i + 1 :]:
            if a.quarter_turns % 2 != b.quarter_turns % 2:
                continue
            (ax0, ay0, ax1, ay1), (bx0, by0, bx1, by1) = (
                a.footprint_boxes()[0],
                b.footprint_boxes()[0],
            )
            if a.quarter_turns % 2 == 0 and min(ay1, by1) - max(ay0, by0) > 0:
                gaps.append(max(bx0 - ax1, ax0 - bx1))
            if a.quarter_turns % 2 == 1 and min(ax1, bx1) - max(ax0, bx0) > 0:
                gaps.append(max(by0 - ay1, ay0 - by1))
    return gaps


def test_joint_kinds_and_rail_gaps_on_both_sides_of_a_finger(batch):
    kinds = set()
    for asm in batch:
        joints = end_joints(asm.parts)
        for j in joints:
            host = asm.parts[j.host]
            stem = np.asarray(asm.parts[j.part].xy)
            along = abs((stem - np.asarray(host.xy)) @ np.asarray(j.direction)[::-1])
            flush = math.isclose(along, host.type.length / 2 - 20, abs_tol=0.5)
            kinds.add("l_corner" if flush else "t_joint")
        ends = [s for s in asm.surfaces() if s.index in (1, 3) and s.type != 4]
        if any(
            a.part != b.part and a.normal == tuple(-v for v in b.normal) and a.center == b.center
            for a in ends
            for b in ends
        ):
            kinds.add("end_to_end")
    assert kinds == {"l_corner", "t_joint", "end_to_end"}
    gaps = [g for asm in batch for g in _rail_gaps(asm) if g > 0.5]
    assert any(g < FINGER for g in gaps) and any(g > FINGER for g in gaps)


def test_unknown_joint_kind_is_a_clear_error(sim_cfg):
    cfg = {**sim_cfg["generator"], "joint_weights": {"weld": 1.0}}
    with pytest.raises(ValueError, match=r"dual_arm.yaml.*joint_weights.*weld"):
        StructureGenerator(finger_mm=FINGER, **cfg)


# --- joints and motions -----------------------------------------------------------------------


def test_t_joint_slides_along_its_axis_end_to_end_and_bracket_drop(world):
    profile, bracket, build = world.profile, world.bracket, world.build
    bar = profile(300, 0, 0, along_x=True)
    stem = profile(200, 40, 120)
    extension = profile(200, 250, 0, along_x=True)
    asm = build(bar, stem, extension, bracket(60, 20, 0))
    joints = end_joints(asm.parts)
    assert [(j.part, j.end, j.host, j.direction) for j in joints] == [(1, 3, 0, (0, -1))]
    motions = insertion_motions(asm, slide_length=50, approach_height=80)
    assert [m.kind for m in motions[1]] == ["slide"]
    np.testing.assert_allclose(motions[1][0].waypoints, [[0, 50, 80], [0, 50, 0], [0, 0, 0]])
    assert [m.kind for ms in (motions[0], motions[2], motions[3]) for m in ms] == ["top_down"] * 3
    touch = touching(asm)
    assert touch[0, 1] and touch[0, 2] and touch[3, 0] and touch[3, 1]
    assert not touch[1, 2]


def test_rung_between_two_bars_has_one_slide_per_joined_end(world):
    profile, build = world.profile, world.build
    low = profile(300, 0, 0, along_x=True)
    high = profile(300, 0, 240, along_x=True)
    rung = profile(200, 0, 120)
    motions = insertion_motions(build(low, high, rung), 60, 60)
    assert sorted(m.direction for m in motions[2]) == [(0.0, -1.0), (0.0, 1.0)]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"bracket_share": None}, r"missing field 'generator.bracket_share'"),
        ({"colour": 1}, r"unknown field 'generator.colour'"),
        ({"gap_mm": [15, 100]}, r"field 'generator.gap_mm'.*straddle"),
    ],
)
def test_bad_generator_config_names_file_and_field(sim_cfg, change, message):
    cfg = {**sim_cfg["generator"], **change}
    cfg = {k: v for k, v in cfg.items() if v is not None}
    with pytest.raises(ValueError, match=r"dual_arm.yaml: " + message):
        StructureGenerator(finger_mm=FINGER, **cfg)
