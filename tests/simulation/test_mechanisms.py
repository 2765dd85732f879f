"""One hand-built frame per mechanism, labelled by the real MuJoCo cell, with its known orders.

Part numbers are the order of the `build(...)` arguments. Every listed order is replayed step by
step by the uncached MuJoCo check, and every other permutation must fail at some step.
"""

import itertools

import pytest


def narrow(w):
    """Two 200 mm stems on one bar, 8 mm apart: no room for a finger beside the first."""
    p = w.profile
    return w.build(p(300, 0, 0, True), p(200, -24, 120), p(200, 24, 120))


def wide(w):
    p = w.profile
    return w.build(p(300, 0, 0, True), p(200, -50, 120), p(200, 50, 120))


def closed_rectangle(w):
    """Two bars, two rungs flush with their ends: whichever closes the frame cannot go in."""
    p = w.profile
    return w.build(p(300, 0, 0, True), p(300, 0, 240, True), p(200, -130, 120), p(200, 130, 120))


def ladder(w):
    """Rungs set in, inside the bars' outer grasp spots: the last bar, held outside the rungs,
    slides onto both."""
    p = w.profile
    return w.build(p(300, 0, 0, True), p(300, 0, 240, True), p(200, -40, 120), p(200, 40, 120))


def t_bracket(w):
    """A T-joint with a bracket in one inner corner, gripped across a leg 20 mm deep: the
    bracket comes after one of its profiles and before the other."""
    p = w.profile
    return w.build(p(300, 0, 0, True), p(200, 0, 120), w.bracket(20, 20, 0))


def corridor(w):
    """Part 3 lies where stem 1 slides into the bar, touching neither: 1 before 3."""
    p = w.profile
    return w.build(p(300, 0, 0, True), p(200, 0, 120), p(300, 120, 170), p(200, 0, 270, True))


CASES = {
    "narrow_rails": (narrow, set(), ["narrow_rails"]),
    "wide_rails": (wide, {(0, 1, 2), (0, 2, 1), (1, 0, 2), (2, 0, 1)}, []),
    "frame_closing": (closed_rectangle, set(), ["frame_closing", "crowded_grasp"]),
    "ladder": (
        ladder,
        {(b, r, s, c) for b, c in ((0, 1), (1, 0)) for r, s in ((2, 3), (3, 2))}
        | {(r, b, s, c) for b, c in ((0, 1), (1, 0)) for r, s in ((2, 3), (3, 2))},
        [],
    ),
    "bracket_corner": (t_bracket, {(0, 2, 1), (1, 2, 0)}, []),
    "slide_corridor": (corridor, {(0, 1, 2, 3), (0, 2, 1, 3), (1, 0, 2, 3), (2, 0, 1, 3)}, []),
}


@pytest.mark.parametrize("name", list(CASES))
def test_hand_case_has_its_known_orders_and_replays(real_sim, world, name):
    make, orders, mechanisms = CASES[name]
    assembly = make(world)
    sample = real_sim.label(assembly)
    assert set(sample.truth.orders()) == orders
    assert sample.info["mechanisms"] == mechanisms
    for order in itertools.permutations(range(assembly.n_parts)):
        assert (real_sim.replay(assembly, order) is None) == (order in orders), order


def test_bracket_grip_decides(real_sim, world):
    """Without finger clearance the bracket could also come last."""
    assembly = t_bracket(world)
    free = real_sim.label(assembly)
    assert "fingers" in free.info["decisive_rules"]
    assert all(o.index(2) == 1 for o in free.truth.orders())
