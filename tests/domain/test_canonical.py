import numpy as np

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.canonical import assembly_key, copy_groups, renumber_masks
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly

PARTS = (
    Part("a", PartType.PROFILE_200, planar_pose(0.0, 0.0)),
    Part("b", PartType.PROFILE_300, planar_pose(60.0, 0.0, 1)),
    Part("c", PartType.BRACKET, planar_pose(0.0, 40.0)),
)


def _rule(order):
    """A placement rule in the numbering `order` (part k of the new numbering is old order[k]):
    old part 2 needs old parts 0 and 1, old part 1 cannot follow old part 2."""

    def can_place(state, part):
        old = int(order[part])
        placed = {int(order[k]) for k in range(3) if state >> k & 1}
        return (old != 2 or placed >= {0, 1}) and not (old == 1 and 2 in placed)

    return can_place


def _sample(order, poses_shift=0.0):
    parts = tuple(Part(PARTS[i].name, PARTS[i].type, PARTS[i].pose + poses_shift) for i in order)
    return LabelledAssembly(Assembly(parts), GroundTruth.explore(3, _rule(order)))


def test_renumber_masks_moves_each_bit_to_the_new_number():
    # part 2 becomes part 0, part 0 part 1, part 1 part 2
    assert list(renumber_masks(np.array([0b001, 0b010, 0b100, 0b101]), np.array([2, 0, 1]))) == [
        0b010,
        0b100,
        0b001,
        0b011,
    ]


def test_a_renumbered_copy_has_the_canonical_key_but_not_the_exact_one():
    original, renumbered = _sample([0, 1, 2]), _sample([2, 0, 1])
    assert original.truth != renumbered.truth  # the bitmasks differ with the numbering
    assert assembly_key(original) == assembly_key(renumbered)
    assert assembly_key(original, renumbered=False) != assembly_key(renumbered, renumbered=False)
    assert assembly_key(original, renumbered=False) == assembly_key(_sample([0, 1, 2]), False)


def test_another_pose_or_ground_truth_is_another_assembly():
    original = _sample([0, 1, 2])
    moved = _sample([0, 1, 2], poses_shift=1e-3)
    other_truth = LabelledAssembly(original.assembly, GroundTruth.explore(3, lambda s, p: True))
    keys = {assembly_key(s) for s in (original, moved, other_truth)}
    assert len(keys) == 3


def test_copy_groups_name_the_first_copy():
    data = [_sample([0, 1, 2]), _sample([1, 2, 0]), _sample([0, 1, 2], 1.0), _sample([0, 1, 2])]
    assert list(copy_groups(data)) == [0, 0, 2, 0]
    assert list(copy_groups(data, renumbered=False)) == [0, 1, 2, 0]
