import numpy as np
import pytest
from grace_tests_conftest import connected

from grace.errors import UserError
from grace.simulation.generator import StructureGenerator
from grace.simulation.joints import (
    end_joints,
    insertion_motions,
    parts_contact,
    parts_overlap,
    touching,
)


@pytest.fixture(scope="module")
def generator(sim_cfg):
    return StructureGenerator(**sim_cfg["generator"])


@pytest.fixture(scope="module")
def batch(generator):
    rng = np.random.default_rng(7)
    return [generator.generate(n, rng) for n in (3, 5, 7, 10, 16) for _ in range(12)]


def test_same_seed_same_assembly(generator):
    a = generator.generate(7, np.random.default_rng(3))
    assert a == generator.generate(7, np.random.default_rng(3))
    assert a != generator.generate(7, np.random.default_rng(4))


def test_frames_are_valid_connected_canonical_and_fit(batch, sim_cfg):
    width, depth = sim_cfg["generator"]["work_area"]
    for asm in batch:
        parts = list(asm.parts)
        assert [p.name for p in parts] == [f"part_{i + 1}" for i in range(len(parts))]
        assert not any(
            parts_overlap(a, b, 0.5) for i, a in enumerate(parts) for b in parts[i + 1 :]
        )
        assert connected(touching(asm))
        boxes = np.array([b for p in parts for b in p.footprint_boxes()])
        lo, hi = boxes[:, :2].min(axis=0), boxes[:, 2:].max(axis=0)
        assert hi[0] - lo[0] <= width and hi[1] - lo[1] <= depth


def test_profiles_meet_only_in_fully_supported_t_slot_joints(batch):
    """Every profile–profile contact is a stem end lying fully on its host's side."""
    for asm in batch:
        for i, a in enumerate(asm.parts):
            for b in asm.parts[i + 1 :]:
                if a.type.is_profile and b.type.is_profile and parts_contact(a, b, 0.5) > 0:
                    assert end_joints([a, b]), asm.name


def test_brackets_sit_in_inner_corners_fastened_to_both_profiles(batch):
    brackets = 0
    for asm in batch:
        for p in asm.parts:
            if p.type.is_profile:
                continue
            brackets += 1
            touched = [q for q in asm.parts if q is not p and parts_contact(p, q, 0.5) > 0]
            assert len(touched) == 2 and all(q.type.is_profile for q in touched)
            assert all(parts_contact(p, q, 0.5) >= 39.5 for q in touched)
    assert brackets > 0


def test_frames_contain_closed_frames_corners_and_narrow_combs(batch):
    """Motifs show up: profiles joined at both ends, L corners, stems a finger-gap apart."""
    both_ends = l_corner = narrow = 0
    for asm in batch:
        joints = end_joints(asm.parts)
        ends = {}
        for j in joints:
            ends.setdefault(j.part, set()).add(j.end)
            host = asm.parts[j.host]
            l_corner += abs(abs(j.along) - (host.type.length / 2 - 20)) < 0.5
        both_ends += any(len(e) == 2 for e in ends.values())
        for j in joints:
            for k in joints:
                if j.host == k.host and j.part < k.part and j.direction == k.direction:
                    narrow += abs(abs(j.along - k.along) - 40) < 12
    assert both_ends and l_corner and narrow


def test_host_slides_onto_placed_connectors_and_stem_slides_into_its_host(world):
    p = world.profile
    bar, stem = p(300, 0, 0, True), p(200, 40, 120)
    asm = world.build(bar, stem)
    motions = insertion_motions(asm, slide_length=60, slide_lead=20, carry_heights=[80])
    # The stem: a drop (blocked by its host) or slides; into the bar (−y) nothing is missed.
    drop, *slides = motions[1]
    assert drop.kind == "top_down" and drop.joint_blockers == 0b01
    into = [m for m in slides if m.direction == (0.0, -1.0)]
    assert into and all(m.joint_blockers == 0 for m in into)
    np.testing.assert_allclose(into[0].waypoints, [[0, 60, 80], [0, 60, 0], [0, 0, 0]])
    away = [m for m in slides if m.direction == (0.0, 1.0)]
    assert all(m.joint_blockers == 0b01 for m in away)  # the host would be behind it
    # The bar after the stem: it slides along x until the connector at x = 40 is taken in.
    by_travel = {(m.direction, round(m.travel)): m.joint_blockers for m in motions[0][1:]}
    # Moving +x the connector enters at the +x end: 150 − 40 + 20 (its half width) + 20 lead.
    assert by_travel[((1.0, 0.0), 60)] == 0b10
    assert by_travel[((1.0, 0.0), 150)] == 0
    assert by_travel[((-1.0, 0.0), 230)] == 0  # moving −x: 150 + 40 + 20 + 20


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"bracket_share": None}, r"bracket_share"),
        ({"colour": 1}, r"colour"),
        ({"motif_weights": {"weld": 1.0}}, r"motif_weights.*weld"),
        ({"gap_mm": [40, 10]}, r"gap_mm"),
    ],
)
def test_bad_generator_config_names_the_field(sim_cfg, change, message):
    cfg = {**sim_cfg["generator"], **change}
    cfg = {k: v for k, v in cfg.items() if v is not None}
    with pytest.raises(UserError, match=r"grace/conf/simulator.*" + message):
        StructureGenerator(**cfg)


def test_a_stem_slides_along_its_hosts_grooves_from_their_open_ends(world):
    """Rung 3 of a rectangle, bar 0 capped at +x by part 4: from +x it takes either bar or
    both (60 mm from the ends); taking bar 0 that way is closed by the cap; from −x rung 2's
    connectors lie in both grooves; a connector in the rung's own groove stops every way."""
    p = world.profile
    frame = world.build(
        p(300, 0, 0, True),
        p(300, 0, 240, True),
        p(200, -130, 120),
        p(200, 130, 120),
        p(200, 170, -80),
    )
    motions = insertion_motions(frame, slide_length=60, slide_lead=20, carry_heights=[80])
    side = {
        (m.direction, round(m.travel), m.joint_blockers)
        for m in motions[3]
        if m.kind == "side_slide"
    }
    from_plus_x = {(b, t) for d, t, b in side if d == (-1.0, 0.0)}
    assert from_plus_x == {(0b10010, 60), (0b00001, 60), (0b10000, 60)}
    from_minus_x = {(b, t) for d, t, b in side if d == (1.0, 0.0)}
    assert from_minus_x == {(0b0110, 320), (0b0101, 320), (0b0100, 320)}
    # A bracket in the rung's inner corner puts a connector into the rung's own groove.
    braced = world.build(*frame.parts, world.bracket(110, 20, 1))
    rung = [m for m in insertion_motions(braced, 60, 20, [80])[3] if m.kind == "side_slide"]
    assert rung and all(m.joint_blockers >> 5 & 1 for m in rung)
