"""The MuJoCo robot cell: finger clearance, swept corridors, clamps, reach, the blocker cache."""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pytest

from grace.domain.assembly import Assembly, Part, PartType, mask_to_parts, planar_pose
from grace.domain.motion import Motion
from grace.errors import UserError
from grace.simulation.robot_cell import RobotCell, category

DROP = Motion("top_down", np.array([[0.0, 0.0, 160.0], [0.0, 0.0, 0.0]]))
"""Lowered from above every clamp (a part carried in lower sweeps through what stands taller)."""
LOW = Motion("top_down", np.array([[0.0, 0.0, 75.0], [0.0, 0.0, 0.0]]))
"""Carried in above the clamps' bases, below a closed toggle clamp's handle."""


def slide(dx: float, dy: float, length: float = 60.0, height: float = 160.0) -> Motion:
    """Lowered `length` back from the joint, then slid along (dx, dy) into it."""
    back = [-dx * length, -dy * length]
    return Motion("slide", np.array([[*back, height], [*back, 0.0], [0, 0, 0]]), (dx, dy))


def build(*parts: tuple[PartType, float, float, int]) -> Assembly:
    return Assembly(
        tuple(Part(f"part_{i}", t, planar_pose(x, y, q)) for i, (t, x, y, q) in enumerate(parts))
    )


@pytest.fixture(scope="module")
def cfg(sim_cfg) -> dict:
    return sim_cfg["cell"]


@pytest.fixture(scope="module")
def cell(cfg) -> RobotCell:
    return RobotCell(**cfg)


def _rails(gap: float) -> Assembly:
    """Two parallel 200 mm profiles along y, `gap` mm apart."""
    p = PartType.PROFILE_200
    return build((p, 0.0, 0.0, 0), (p, 40.0 + gap, 0.0, 0))


def test_a_finger_does_not_fit_a_gap_narrower_than_itself(cell, cfg):
    narrow = _rails(cfg["gripper"]["finger_thickness"] - 4)
    options = cell.placement_options(narrow, 0, [DROP])
    assert options and all(o.masks[category("finger", "part")] == 0b10 for o in options)
    assert not cell.check_placement(narrow, 0, 0b10, DROP)
    assert cell.check_placement(narrow, 0, 0b00, DROP)


def test_a_finger_fits_a_wide_gap(cell, cfg):
    wide = _rails(cfg["gripper"]["finger_thickness"] + 8)
    options = cell.placement_options(wide, 0, [DROP])
    assert any(o.free(0b10) for o in options)
    assert cell.check_placement(wide, 0, 0b10, DROP)


def test_a_slide_is_blocked_by_a_part_in_its_corridor_only(cell):
    p = PartType.PROFILE_200
    corridor = build((p, 0.0, 0.0, 0), (p, 0.0, -130.0, 1))  # crosses the path behind the end
    beside = build((p, 0.0, 0.0, 0), (p, 250.0, -130.0, 1))
    into_joint = slide(0.0, 1.0)
    blocked = cell.placement_options(corridor, 0, [into_joint, DROP])
    held = category("held_part", "part")
    assert all(o.masks[held] == 0b10 for o in blocked if o.motion == 0)
    assert any(o.free(0b10) for o in blocked if o.motion == 1)
    assert not cell.check_placement(corridor, 0, 0b10, into_joint)
    assert cell.check_placement(corridor, 0, 0b10, DROP)
    assert cell.check_placement(beside, 0, 0b10, into_joint)


def test_a_part_out_of_reach_has_no_reachable_option(cell):
    far = build((PartType.PROFILE_200, 1500.0, 0.0, 0))
    assert not any(o.reachable for o in cell.placement_options(far, 0, [DROP]))
    assert not cell.check_placement(far, 0, 0, DROP)


def test_every_profile_gets_a_clamp_on_a_free_spot(cell, cfg):
    """A toggle clamp where it leaves a finger's room, a swing clamp in a tight spot; every
    base touches its profile and stands on no part, the closed bar or arm lies on its top."""
    p = PartType.PROFILE_300
    # Rails 44 mm apart: a 40 mm clamp between them leaves no finger's room on either side.
    frame = build((p, 0.0, 0.0, 1), (PartType.PROFILE_200, -60.0, 120.0, 0))
    tight = build((p, 0.0, 0.0, 1), (p, 0.0, 84.0, 1), (p, 0.0, -84.0, 1))
    finger = cfg["gripper"]["finger_thickness"]
    types = {t["name"]: t for t in cfg["clamp"]["types"]}
    kinds = {c.kind for c in cell.scene(frame).clamps}
    assert kinds == {"toggle"}
    assert cell.scene(tight).clamps[0].kind == "swing"
    for assembly in (frame, tight):
        for part, clamp in zip(assembly.parts, cell.scene(assembly).clamps, strict=True):
            spec = types[clamp.kind]
            assert len(clamp.boxes) == len(spec["boxes"])
            base, bar = clamp.boxes[0], clamp.boxes[1]
            assert base[0, 2] == 0 and base[1, 2] == bar[1, 2] == 55 and bar[0, 2] == 40
            x0, y0, x1, y1 = part.footprint_boxes()[0]
            gap = max(base[0, 0] - x1, x0 - base[1, 0], base[0, 1] - y1, y0 - base[1, 1])
            assert abs(gap) < 0.5  # against its profile's side
            for other in assembly.parts:
                for ox0, oy0, ox1, oy1 in other.footprint_boxes():
                    dx = min(base[1, 0], ox1) - max(base[0, 0], ox0)
                    dy = min(base[1, 1], oy1) - max(base[0, 1], oy0)
                    assert not (dx > 0.5 and dy > 0.5)
                    if clamp.kind == "toggle" and other is not part:
                        assert min(dx, dy) < 0.5 - finger  # a finger's room all round


def test_a_part_is_carried_in_above_what_stands_then(cell):
    """Rails 300 mm apart, each with a toggle clamp: carried in at 75 mm, rail 0 sweeps through
    rail 1's handle once rail 1 is clamped; lowered from 160 mm it clears it."""
    p = PartType.PROFILE_200
    rails = build((p, 0.0, 0.0, 0), (p, 300.0, 0.0, 0))
    assert [c.kind for c in cell.scene(rails).clamps] == ["toggle", "toggle"]
    options = cell.placement_options(rails, 0, [LOW, DROP])
    low = [o for o in options if o.motion == 0]
    assert all(o.masks[category("held_part", "clamp")] == 0b10 for o in low)
    assert any(o.free(0) for o in low) and not any(o.free(0b10) for o in low)
    assert any(o.free(0b10) for o in options if o.motion == 1)
    assert cell.check_placement(rails, 0, 0, LOW)
    assert not cell.check_placement(rails, 0, 0b10, LOW)
    assert cell.check_placement(rails, 0, 0b10, DROP)


def _frame() -> tuple[Assembly, list[list[Motion]]]:
    """A bar, two stems 8 mm apart, a bracket in an inner corner, a profile across a corridor."""
    p2, p3, b = PartType.PROFILE_200, PartType.PROFILE_300, PartType.BRACKET
    assembly = build(
        (p3, 0.0, 0.0, 1),
        (p2, -100.0, 120.0, 0),
        (p2, -52.0, 120.0, 0),
        (b, -32.0, 20.0, 0),
        (p2, -10.0, 270.0, 1),
    )
    into_bar = slide(0.0, -1.0)
    return assembly, [[DROP], [into_bar], [into_bar, DROP], [DROP], [DROP]]


@pytest.mark.parametrize("variant", ["default", "open_bar"])
def test_blockers_agree_with_the_uncached_mujoco_check(cell, world, variant):
    """Every option's masks against the uncached check in every state; with the toggle clamps'
    bar standing up while open, some options wait for a clamp to close."""
    if variant == "open_bar":
        cell = RobotCell(**world.config("dual_arm", "simulator/cell=iiwa14_dual_open_bar")["cell"])
    assembly, motions = _frame()
    n = assembly.n_parts
    scene = cell.scene(assembly)
    if variant == "open_bar":  # an open bar in a neighbour's way, and in its own profile's
        needs = [(p, o.needs) for p in range(n) for o in cell.part_options(scene, p, motions[p])]
        assert any(m & ~(1 << p) for p, m in needs) and any(m >> p & 1 for p, m in needs)
    for part in range(n):
        options = cell.part_options(scene, part, motions[part])
        others = [i for i in range(n) if i != part]
        for m, motion in enumerate(motions[part]):
            for k in range(len(others) + 1):
                for subset in combinations(others, k):
                    state = sum(1 << i for i in subset)
                    cached = any(o.free(state) for o in options if o.motion == m)
                    assert cell.check_placement(assembly, part, state, motion) == cached, (
                        part,
                        m,
                        mask_to_parts(state),
                    )
        cell.scene(assembly)


def test_bad_config_names_the_field(cfg):
    broken = {k: v for k, v in cfg.items() if k != "touch_tolerance"}
    with pytest.raises(UserError, match="touch_tolerance"):
        RobotCell(**broken)
    with pytest.raises(UserError, match=r"finger_size"):
        RobotCell(**{**cfg, "gripper": {**cfg["gripper"], "finger_size": 3}})
    with pytest.raises(UserError, match=r"palm_width"):
        RobotCell(**{**cfg, "gripper": {**cfg["gripper"], "palm_width": 50}})
    toggle, swing = cfg["clamp"]["types"]
    for broken_type, why in (
        ({**toggle, "boxes": [{**toggle["boxes"][0], "when": "later"}]}, "when: always"),
        ({**toggle, "boxes": [*toggle["boxes"], {**toggle["boxes"][1], "when": "later"}]}, "later"),
        ({**toggle, "boxes": [{**toggle["boxes"][0], "z": [55, 0]}]}, "from < to"),
    ):
        clamp = {**cfg["clamp"], "types": [broken_type, swing]}
        with pytest.raises(UserError, match=rf"clamp.types.*toggle.*{why}"):
            RobotCell(**{**cfg, "clamp": clamp})


def test_too_many_parts_for_the_slot_pool(cfg):
    small = RobotCell(**{**cfg, "max_parts": 2})
    rails = build(*[(PartType.PROFILE_200, 60.0 * i, 0.0, 0) for i in range(4)])
    with pytest.raises(UserError, match="max_parts"):
        small.placement_options(rails, 0, [DROP])
