import itertools

import numpy as np
import pytest

from grace.domain.assembly import PartType
from grace.simulation.feasibility import Fixation, PlacementTable, label, replay
from grace.simulation.joints import insertion_motions, touching


def _label(assembly, cell):
    motions = insertion_motions(assembly, slide_length=60, approach_height=60)
    return label(assembly, cell, motions, touching(assembly))


def _before(order, a, b):
    return order.index(a) < order.index(b)


def rails(w, gap: float):
    """A bar along x with two stems standing on it `gap` mm apart: 300 mm (part 1), 200 mm (2)."""
    profile = w.profile
    bar = profile(300, 0, 0, along_x=True)
    long_stem = profile(300, -40, 20 + 150)
    short_stem = profile(200, 0 + gap, 20 + 100)
    return w.build(bar, long_stem, short_stem)


# --- fixation, coordinate-free --------------------------------------------------------------


class _Types:
    def __init__(self, kinds):
        self.parts = [type("P", (), {"type": k})() for k in kinds]
        self.n_parts = len(kinds)


def test_fixation_first_profile_clamped_later_profiles_need_contact():
    touch = np.array([[0, 1, 0], [1, 0, 1], [0, 1, 0]], dtype=bool)
    fix = Fixation.of(_Types([PartType.PROFILE_200] * 3), touch)
    assert all(fix.holds(0, p) for p in range(3))
    assert fix.holds(0b001, 1) and not fix.holds(0b001, 2)
    assert fix.holds(0b010, 2) and fix.holds(0b010, 0)


def test_fixation_bracket_needs_both_profiles_and_is_never_first():
    kinds = [PartType.PROFILE_300, PartType.PROFILE_200, PartType.BRACKET]
    touch = np.array([[0, 1, 1], [1, 0, 1], [1, 1, 0]], dtype=bool)
    fix = Fixation.of(_Types(kinds), touch)
    assert not fix.holds(0, 2)
    assert not fix.holds(0b001, 2) and not fix.holds(0b010, 2)
    assert fix.holds(0b011, 2)


def test_minimal_blockers_and_cached_rule():
    class Opt:
        def __init__(self, reachable, blockers):
            self.reachable, self.blockers = reachable, blockers

    class Cell:
        def placement_options(self, assembly, part, motions):
            return {0: [Opt(True, 0)], 1: [Opt(True, 0b100), Opt(True, 0b101)], 2: [Opt(False, 0)]}[
                part
            ]

    kinds = _Types([PartType.PROFILE_200] * 3)
    touch = np.ones((3, 3), dtype=bool) & ~np.eye(3, dtype=bool)
    table = PlacementTable.build(kinds, Cell(), [[], [], []], touch)
    assert table.reachable == ((0,), (0b100,), ())
    assert table.clearance[2] == (0,)
    assert table.can_place(0b001, 1) and not table.can_place(0b101, 1)
    assert not table.can_place(0, 2) and table.can_place_ignoring_reach(0, 2)


# --- hand-built geometry with the fake cell ---------------------------------------------------


def test_finger_wide_gap_forbids_one_order_wide_gap_allows_both(world):
    narrow = _label(rails(world, gap=10), world.FakeCell())
    assert narrow.truth.feasible
    orders = list(narrow.truth.orders())
    assert orders and all(_before(o, 2, 1) for o in orders)
    assert narrow.info["robot_pruned"] and narrow.info["nonlocal_block"]

    wide = _label(rails(world, gap=60), world.FakeCell())
    orders = list(wide.truth.orders())
    assert any(_before(o, 2, 1) for o in orders) and any(_before(o, 1, 2) for o in orders)
    assert not wide.info["nonlocal_block"]


def test_narrow_gap_between_equal_stems_is_a_collision_infeasibility(world):
    bar = world.profile(300, 0, 0, along_x=True)
    stems = world.profile(200, -30, 120), world.profile(200, 20, 120)
    sample = _label(world.build(bar, *stems), world.FakeCell())
    assert not sample.truth.feasible
    assert sample.info["cause"] == "collision"


def corridor(w):
    """H bar; S stem on it; C caps post T and lies 30 mm beyond S's far end (slide is 60)."""
    profile = w.profile
    h = profile(300, 0, 0, along_x=True)
    s = profile(200, 0, 120)
    t = profile(300, 120, 170)
    c = profile(200, 0, 270, along_x=True)
    return w.build(h, s, t, c)


def test_part_in_slide_corridor_must_come_after_the_stem(world):
    sample = _label(corridor(world), world.FakeCell())
    orders = list(sample.truth.orders())
    assert orders and all(_before(o, 1, 3) for o in orders)
    assert sample.info["nonlocal_block"] and sample.info["robot_pruned"]
    assert not touching(corridor(world))[1, 3]


def l_with_bracket(w):
    profile = w.profile
    h = profile(300, 0, 0, along_x=True)
    v = profile(200, -130, 120)
    return w.build(h, v, w.bracket(-110, 20, 0))


def test_bracket_before_its_profiles_is_impossible(world):
    sample = _label(l_with_bracket(world), world.FakeCell())
    assert sample.truth.feasible
    assert all(o[-1] == 2 for o in sample.truth.orders())
    for state, placeable in zip(sample.truth.states, sample.truth.placeable, strict=True):
        if placeable >> 2 & 1:
            assert state & 0b011 == 0b011


def test_part_out_of_reach_makes_assembly_infeasible(world):
    chain = world.build(*[world.profile(300, 300 * k, 0, along_x=True) for k in range(5)])
    assert _label(chain, world.FakeCell()).truth.feasible
    short_reach = _label(chain, world.FakeCell(reach_mm=400))
    assert not short_reach.truth.feasible
    assert short_reach.info["cause"] == "reach"


@pytest.mark.parametrize(
    "make", [lambda w: rails(w, 10), corridor, l_with_bracket], ids=["rails", "corridor", "bracket"]
)
def test_every_listed_order_replays_and_no_other_does(world, make):
    assembly = make(world)
    cell = world.FakeCell()
    motions = insertion_motions(assembly, 60, 60)
    touch = touching(assembly)
    sample = label(assembly, cell, motions, touch)
    listed = set(sample.truth.orders())
    for order in itertools.permutations(range(assembly.n_parts)):
        failed = replay(assembly, order, cell, motions, touch)
        assert (failed is None) == (order in listed), order
