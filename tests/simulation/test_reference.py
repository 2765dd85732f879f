"""The enumerator against the brute-force reference that offers every documented move, and the
clamps against every grasp the labels use."""

import numpy as np
import pytest
from hydra.utils import instantiate

from grace.data.store import assembly_rng
from grace.simulation.clearance import part_boxes
from grace.simulation.joints import connectors, end_joints
from grace.simulation.reference import brute_force_truth, command_line, compare, joint_allows

OPEN_BAR_CHANGED = ((5, 2), (5, 94), (6, 1), (6, 32), (6, 67), (6, 97))
"""Data seed 11: the open-bar cell's A5 / A6 frames (of 100 each) whose labels changed once the
arm links met open clamp solids: 30 orders fewer, three frames infeasible."""


def generated(sim, size: int, index: int):
    return sim.generate(size, np.random.default_rng(np.random.SeedSequence([0, size, index])))


@pytest.mark.parametrize(("size", "index"), [(5, 1), (5, 26), (6, 0), (7, 0)])
def test_the_enumerator_finds_what_every_documented_move_allows(real_sim, size, index):
    """A5 seeds 1 and 26: 5 and 10 orders with the slide along a host's groove, 0 and 1
    without it."""
    assembly = generated(real_sim, size, index)
    assert brute_force_truth(real_sim, assembly) == real_sim.label(assembly).truth


@pytest.mark.slow
def test_the_enumerator_agrees_with_the_reference_on_120_generated_frames(real_sim):
    """`python -m grace.simulation.reference 5,6,7 40` prints the same comparison."""
    for size in (5, 6, 7):
        for index in range(40):
            assembly = generated(real_sim, size, index)
            truth = real_sim.label(assembly).truth
            assert brute_force_truth(real_sim, assembly) == truth, (size, index)


@pytest.mark.slow
def test_the_open_bar_labels_agree_with_the_uncached_replay(world):
    """Every order of the frames that open bars in the arm's way changed: the labels list it iff
    `Simulator.replay` lets it through. `python -m grace.simulation.reference 5,6,7 40 --seed 11
    --against replay simulator/cell=iiwa14_dual_open_bar` checks 120 frames."""
    sim = instantiate(world.config("dual_arm", "simulator/cell=iiwa14_dual_open_bar"))
    for size, index in OPEN_BAR_CHANGED:
        row = compare(sim, sim.generate(size, assembly_rng(11, size, index)), "replay")
        assert row["agree"], (size, index, row)


def test_the_command_line_takes_options_between_its_arguments():
    read = command_line().parse_intermixed_args
    args = read(["5,6,7", "40", "--seed", "11", "--against", "replay", "simulator/cell=x"])
    assert (args.sizes, args.count, args.seed, args.against) == ("5,6,7", 40, 11, "replay")
    assert args.overrides == ["simulator/cell=x"]
    default = read(["5,6,7", "40"])
    assert (default.seed, default.against, default.overrides) == (0, "reference", [])


def test_the_reference_joint_rule_on_the_last_rung(world):
    """Rung 3 of a rectangle with both bars placed: along the grooves from the +x ends (60 mm
    suffice) or not at all; a cap over bar 0's +x end closes that way."""
    p = world.profile
    rect = world.build(
        p(300, 0, 0, True), p(300, 0, 240, True), p(200, -130, 120), p(200, 130, 120)
    )
    capped = world.build(*rect.parts, p(200, 170, -80))
    for assembly, open_end in ((rect, True), (capped, False)):
        grooves, joints = connectors(assembly.parts), end_joints(assembly.parts)
        placed = (1 << assembly.n_parts) - 1 & ~(1 << 3)

        def allows(direction, travel, placed=placed, a=assembly, g=grooves, j=joints):
            return joint_allows(a, 3, placed, direction, travel, 20.0, g, j)

        assert allows((-1, 0), 60.0) == open_end
        assert not allows((-1, 0), 59.0)  # it would start with its connectors in the grooves
        assert not allows((1, 0), 400.0)  # rung 2's connectors are in the way from −x
        assert not allows(None, 0.0) and not allows((0, 1), 60.0)  # lowered or into one bar


@pytest.mark.slow  # every frame of two cells; the open-bar minimal case has a fast test
@pytest.mark.parametrize("variant", ["default", "open_bar"])
def test_no_grasp_ends_inside_a_clamp_that_stands_then(real_sim, world, variant):
    """Every option the labels may use, in every reachable state of generated frames: its
    fingers, gripper body and held part at the final pose clear every clamp solid standing in
    that state (bases from the start, open bars until their profile is placed, also while it is
    placed, arms and handles once it is)."""
    sim = real_sim
    if variant == "open_bar":
        sim = instantiate(world.config("dual_arm", "simulator/cell=iiwa14_dual_open_bar"))
    checked = 0
    for size, index in ((6, 0), (7, 0)):
        assembly = generated(sim, size, index)
        truth = sim.label(assembly).truth
        scene = sim.cell.scene(assembly)
        for state in truth.states.tolist():
            placed = [q for q in range(size) if state >> q & 1]
            standing = scene.present(placed) & (scene.kind != 0)
            obstacles = np.stack([scene.lo[standing], scene.hi[standing]], axis=1)
            for part in range(size):
                if state >> part & 1:
                    continue
                verdict = sim.explain(assembly, state, part)
                grasps = sim.cell.grasps(assembly, part)
                held = part_boxes(assembly.parts[part])
                for candidate in verdict.candidates:
                    if not candidate.feasible:
                        continue
                    tool = grasps[candidate.grasp].gripper_boxes(sim.cell.config.gripper)
                    solid = np.concatenate([tool, held])
                    depth = np.minimum(solid[:, None, 1], obstacles[None, :, 1]) - np.maximum(
                        solid[:, None, 0], obstacles[None, :, 0]
                    )
                    assert not (depth > 0.5).all(axis=-1).any(), (size, index, state, part)
                    checked += 1
    assert checked > 100
