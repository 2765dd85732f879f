"""Large frames in sections (simulator=large_frames) and the cell whose arms ride on tracks.

The geometry of a sectioned frame (connected, T-slot joints only, within the frame's area,
deterministic per seed), what the section check is asked, and that the track gives the arms
the reach along the long table that fixed pedestals do not."""

import numpy as np
import pytest
from grace_tests_conftest import connected
from hydra.utils import instantiate

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.simulation.generator import StructureGenerator
from grace.simulation.joints import end_joints, parts_contact, parts_overlap, touching
from grace.simulation.robot_cell import RobotCell
from grace.simulation.sections import section_sizes


@pytest.fixture(scope="module")
def large_cfg(world):
    return world.config("large_frames")


def test_section_sizes_fill_the_frame_with_a_link_between_sections():
    for n, most in ((21, 8), (30, 8), (50, 8), (50, 10)):
        sizes = section_sizes(n, most)
        assert sum(sizes) + len(sizes) - 1 == n
        assert max(sizes) <= most and max(sizes) - min(sizes) <= 1


def test_a_sectioned_frame_is_connected_by_t_slot_joints_within_its_area(large_cfg):
    generator = StructureGenerator(**large_cfg["generator"])
    asked = []

    def accept(piece: Assembly, head: int) -> bool:
        asked.append((piece.n_parts, head))
        return True

    frame = generator.generate(40, np.random.default_rng(5), accept)
    again = generator.generate(40, np.random.default_rng(5), lambda *_: True)
    assert frame == again  # deterministic per seed, whatever the check costs
    assert frame.n_parts == 40
    assert connected(touching(frame))
    parts = frame.parts
    assert not any(parts_overlap(a, b, 0.5) for i, a in enumerate(parts) for b in parts[i + 1 :])
    profiles = [p for p in parts if p.type.is_profile]
    pairs = sum(
        parts_contact(a, b, 0.5) > 0 for i, a in enumerate(profiles) for b in profiles[i + 1 :]
    )
    assert len(end_joints(profiles)) == pairs  # every profile contact is a T-slot joint
    boxes = np.array([b for p in parts for b in p.footprint_boxes()])
    width, depth = large_cfg["generator"]["frame_area"]
    assert boxes[:, 2].max() - boxes[:, 0].min() <= width
    assert boxes[:, 3].max() - boxes[:, 1].min() <= depth
    # the first section alone, then each later one behind the previous section and its link
    sizes = section_sizes(40, large_cfg["generator"]["section_parts"])
    assert asked[0] == (sizes[0], sizes[0])
    assert [n for n, _ in asked[1:]] == [
        (1 if i > 1 else 0) + sizes[i - 1] + 1 + sizes[i] for i in range(1, len(sizes))
    ]


def test_frames_up_to_the_section_size_grow_whole_as_in_the_default_world(large_cfg, sim_cfg):
    # Only the work area differs from the default generator below section_parts.
    cfg = {**large_cfg["generator"], "work_area": sim_cfg["generator"]["work_area"]}
    sectioned = StructureGenerator(**cfg)
    default = StructureGenerator(**sim_cfg["generator"])
    for seed in range(3):
        a = sectioned.generate(7, np.random.default_rng(seed), lambda *_: False)
        assert a == default.generate(7, np.random.default_rng(seed))


def test_the_track_carries_the_arm_opposite_a_part_beyond_the_fixed_pedestals_reach(
    large_cfg, sim_cfg
):
    far = Assembly((Part("far", PartType.PROFILE_200, planar_pose(0.0, 1400.0, 1)),))
    track = RobotCell(**large_cfg["cell"])
    fixed = RobotCell(**{**large_cfg["cell"], "track": []})
    motions = instantiate(large_cfg).motions(far)[0]
    assert any(o.free(0) for o in track.placement_options(far, 0, motions))
    assert not any(o.reachable for o in fixed.placement_options(far, 0, motions))
    grasp = track.grasps(far, 0)[0]
    assert track.carriage(0, grasp) == pytest.approx(1400.0)
    assert RobotCell(**sim_cfg["cell"]).carriage(0, grasp) == 0.0
    # the uncached reference agrees with the cached options on the track
    assert track.check_placement(far, 0, 0, motions[0]) == any(
        o.free(0) for o in track.placement_options(far, 0, motions) if o.motion == 0
    )


def test_a_piece_is_buildable_only_from_its_first_part(real_sim, world):
    # A rung between two rails: the rails first, the rung slides in sideways.
    rails = world.build(
        world.profile(300, -120, 0), world.profile(300, 120, 0), world.profile(200, 0, 0, True)
    )
    truth = real_sim.truth(rails)
    for first in range(3):
        can = any(order[0] == first for order in truth.orders())
        assert (
            real_sim.buildable_piece(Assembly(tuple(rails.parts[first:] + rails.parts[:first])), 3)
            == can
        )
