"""The MuJoCo robot cell: finger clearance, swept corridors, reach, and the blocker cache."""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pytest
import yaml

from grace import CONF_DIR
from grace.domain.assembly import Assembly, Part, PartType, mask_to_parts, planar_pose
from grace.domain.motion import Motion
from grace.simulation.robot_cell import RobotCell

CELL = CONF_DIR / "simulator" / "cell" / "iiwa14_dual.yaml"
DROP = Motion("top_down", np.array([[0.0, 0.0, 60.0], [0.0, 0.0, 0.0]]))


def slide(dx: float, dy: float, length: float = 60.0, height: float = 60.0) -> Motion:
    """Lowered `length` back from the joint, then slid along (dx, dy) into it."""
    back = [-dx * length, -dy * length]
    return Motion("slide", np.array([[*back, height], [*back, 0.0], [0, 0, 0]]), (dx, dy))


def build(*parts: tuple[PartType, float, float, int]) -> Assembly:
    return Assembly(
        tuple(Part(f"part_{i}", t, planar_pose(x, y, q)) for i, (t, x, y, q) in enumerate(parts))
    )


@pytest.fixture(scope="module")
def cfg() -> dict:
    return yaml.safe_load(CELL.read_text())


@pytest.fixture(scope="module")
def cell(cfg) -> RobotCell:
    return RobotCell(**cfg)


def _rails(gap: float) -> Assembly:
    """Two parallel 200 mm profiles along y, `gap` mm apart."""
    p = PartType.PROFILE_200
    return build((p, 0.0, 0.0, 0), (p, 40.0 + gap, 0.0, 0))


def test_a_finger_does_not_fit_a_gap_narrower_than_itself(cell, cfg):
    finger = cfg["gripper"]["finger_thickness"]
    narrow = _rails(finger - 4)
    options = cell.placement_options(narrow, 0, [DROP])
    assert options and all(o.blockers == 0b10 for o in options)
    assert any(o.reachable for o in options)
    assert not cell.check_placement(narrow, 0, 0b10, DROP)
    assert cell.check_placement(narrow, 0, 0b00, DROP)


def test_a_finger_fits_a_wide_gap(cell, cfg):
    wide = _rails(cfg["gripper"]["finger_thickness"] + 8)
    options = cell.placement_options(wide, 0, [DROP])
    assert any(o.reachable and o.blockers == 0 for o in options)
    assert cell.check_placement(wide, 0, 0b10, DROP)


def test_a_slide_is_blocked_by_a_part_in_its_corridor_only():
    cell_cfg = yaml.safe_load(CELL.read_text())
    cell = RobotCell(**cell_cfg)
    p = PartType.PROFILE_200
    corridor = build((p, 0.0, 0.0, 0), (p, 0.0, -130.0, 1))  # crosses the path behind the end
    beside = build((p, 0.0, 0.0, 0), (p, 250.0, -130.0, 1))
    into_joint = slide(0.0, 1.0)
    blocked = cell.placement_options(corridor, 0, [into_joint, DROP])
    assert all(o.blockers == 0b10 for o in blocked if o.motion == 0)
    assert any(o.reachable and o.blockers == 0 for o in blocked if o.motion == 1)
    assert not cell.check_placement(corridor, 0, 0b10, into_joint)
    assert cell.check_placement(corridor, 0, 0b10, DROP)
    free = cell.placement_options(beside, 0, [into_joint])
    assert any(o.reachable and o.blockers == 0 for o in free)
    assert cell.check_placement(beside, 0, 0b10, into_joint)


def test_a_part_out_of_reach_has_no_reachable_option(cell):
    far = build((PartType.PROFILE_200, 1500.0, 0.0, 0))
    assert not any(o.reachable for o in cell.placement_options(far, 0, [DROP]))
    assert not cell.check_placement(far, 0, 0, DROP)


def _frame() -> tuple[Assembly, list[list[Motion]]]:
    """A bar, two stems on it 8 mm apart (T-joints), a bracket in an inner corner and a loose
    profile in the slide corridor of the second stem."""
    p2, p3, b = PartType.PROFILE_200, PartType.PROFILE_300, PartType.BRACKET
    assembly = build(
        (p3, 0.0, 0.0, 1),  # bar along x, y ∈ [-20, 20]
        (p2, -100.0, 120.0, 0),  # stem, its −y end on the bar
        (p2, -52.0, 120.0, 0),  # stem 8 mm to the right
        (b, -32.0, 20.0, 0),  # bracket between the bar and the second stem
        (p2, -10.0, 270.0, 1),  # lies across the second stem's approach
    )
    into_bar = slide(0.0, -1.0)
    return assembly, [[DROP], [into_bar], [into_bar, DROP], [DROP], [DROP]]


def test_blockers_agree_with_the_uncached_check(cell):
    assembly, motions = _frame()
    n = assembly.n_parts
    for part in range(n):
        options = cell.placement_options(assembly, part, motions[part])
        others = [i for i in range(n) if i != part]
        for m, motion in enumerate(motions[part]):
            for k in range(len(others) + 1):
                for subset in combinations(others, k):
                    state = sum(1 << i for i in subset)
                    cached = any(
                        o.reachable and not o.blockers & state for o in options if o.motion == m
                    )
                    assert cell.check_placement(assembly, part, state, motion) == cached, (
                        part,
                        m,
                        mask_to_parts(state),
                    )


def test_frame_blockers_are_the_expected_neighbours(cell):
    assembly, motions = _frame()
    first_stem = cell.placement_options(assembly, 1, motions[1])
    assert all(o.blockers & 0b100 for o in first_stem)  # the 8 mm gap is too narrow for a finger
    slid = cell.placement_options(assembly, 2, motions[2])
    assert all(o.blockers & 0b10000 for o in slid if o.motion == 0)  # the corridor part
    bracket = cell.placement_options(assembly, 3, motions[3])
    assert any(o.reachable and o.blockers == 0 for o in bracket)  # fits between its profiles


def test_bad_config_names_the_field(cfg):
    broken = {k: v for k, v in cfg.items() if k != "touch_tolerance"}
    with pytest.raises(ValueError, match="touch_tolerance"):
        RobotCell(**broken)
    with pytest.raises(ValueError, match=r"gripper\.finger_size"):
        RobotCell(**{**cfg, "gripper": {**cfg["gripper"], "finger_size": 3}})


def test_too_many_parts_for_the_slot_pool(cfg):
    small = RobotCell(**{**cfg, "max_parts": 2})
    rails = build(*[(PartType.PROFILE_200, 60.0 * i, 0.0, 0) for i in range(4)])
    with pytest.raises(ValueError, match="max_parts"):
        small.placement_options(rails, 0, [DROP])


def test_arm_links_block_too(cfg):
    """A stubby gripper under a fat wrist: the wrist link, not the fingers, hits the neighbour."""
    stubby = {
        **cfg,
        "arm": {**cfg["arm"], "link_radii": [70, 65, 60, 80]},
        "gripper": {**cfg["gripper"], "palm_height": 5, "finger_length": 45, "grasp_height": 35},
    }
    wide = _rails(cfg["gripper"]["finger_thickness"] + 8)
    blocked = RobotCell(**stubby).placement_options(wide, 0, [DROP])
    assert any(o.reachable for o in blocked)
    assert all(o.blockers == 0b10 for o in blocked if o.reachable)
    assert all(o.blockers == 0 for o in blocked if not o.reachable)  # swept gripper alone is clear
