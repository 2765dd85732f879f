"""Hand-built frames labelled by the real MuJoCo cell, each with its known orders.

Part numbers are the order of the `build(...)` arguments. Every listed order is replayed step by
step by the uncached MuJoCo check, every other permutation must fail at some step, and the
brute-force reference (every documented move, the joint rule judged connector by connector)
must find the same ground truth.
"""

import itertools

import numpy as np
import pytest

from grace.simulation.reference import brute_force_truth


def narrow(w):
    """Two 200 mm stems on one bar, 8 mm apart: no room for a finger beside the first."""
    p = w.profile
    return w.build(p(300, 0, 0, True), p(200, -24, 120), p(200, 24, 120))


def wide(w):
    p = w.profile
    return w.build(p(300, 0, 0, True), p(200, -50, 120), p(200, 50, 120))


def bars(w):
    """Two 300 mm bars 200 mm apart: the long sides of a rectangle."""
    p = w.profile
    return p(300, 0, 0, True), p(300, 0, 240, True)


def last_rung(w):
    """A rectangle: two rungs flush with the bars' ends. The last rung slides in along both
    bars' grooves from their open ends; a bar cannot come last (its fingers sweep the rungs)."""
    p = w.profile
    return w.build(*bars(w), p(200, -130, 120), p(200, 130, 120))


def capped(w):
    """The rectangle with a profile across bar 0's +x end (an L corner below it): it closes
    that groove's end, so rung 3 cannot slide in along bar 0 once 4 is placed."""
    p = w.profile
    return w.build(*bars(w), p(200, -130, 120), p(200, 130, 120), p(200, 170, -80))


def groove_connector(w):
    """Rung 3 set in, rung 4 flush at the +x ends. 3's way in along the grooves from +x passes
    4's connectors (and body), from −x rung 2's; 4 has no room inside for its clamp post (50 mm
    to rung 3), which stands outside, in 4's own way in. So 3 and 4 come before a bar, and
    rung 2, sliding in from −x, comes last."""
    p = w.profile
    return w.build(*bars(w), p(200, -130, 120), p(200, 40, 120), p(200, 130, 120))


def clamp_in_path(w):
    """Rung 3 20 mm beside rung 4 leaves no room inside for 4's clamp post: it stands outside,
    in 4's way in from +x, and 3's post, inside, in its way in from −x (placed or not). As
    above, 3 and 4 come before a bar and rung 2 comes last."""
    p = w.profile
    return w.build(*bars(w), p(200, -130, 120), p(200, 70, 120), p(200, 130, 120))


def ladder(w):
    """Rungs set in, inside the bars' outer grasp spots: the last bar, held outside the rungs,
    slides onto both."""
    p = w.profile
    return w.build(*bars(w), p(200, -40, 120), p(200, 40, 120))


def t_bracket(w):
    """A T-joint with a bracket in one inner corner, gripped across a leg 20 mm deep: the
    bracket comes after one of its profiles and before the other."""
    p = w.profile
    return w.build(p(300, 0, 0, True), p(200, 0, 120), w.bracket(20, 20, 0))


def corridor(w):
    """Part 3 lies where stem 1 slides along its own axis into the bar, touching neither: 1
    comes before 3, or after it sliding along the bar's groove from its free −x end."""
    p = w.profile
    return w.build(p(300, 0, 0, True), p(200, 0, 120), p(300, 120, 170), p(200, 0, 270, True))


RUNGS_BEFORE_A_BAR = {
    (0, 3, 4, 1, 2),
    (0, 4, 3, 1, 2),
    (1, 3, 4, 0, 2),
    (1, 4, 3, 0, 2),
    (3, 0, 4, 1, 2),
    (3, 1, 4, 0, 2),
    (4, 0, 3, 1, 2),
    (4, 1, 3, 0, 2),
}
CASES = {
    "narrow_rails": (narrow, set(), ["narrow_rails"]),
    "wide_rails": (wide, {(0, 1, 2), (0, 2, 1), (1, 0, 2), (2, 0, 1)}, []),
    "last_rung": (
        last_rung,
        {(b, r, c, s) for b, c in ((0, 1), (1, 0)) for r, s in ((2, 3), (3, 2))}
        | {(r, b, c, s) for b, c in ((0, 1), (1, 0)) for r, s in ((2, 3), (3, 2))},
        [],
    ),
    "capped": (
        capped,
        {
            (0, 2, 1, 3, 4),
            (0, 3, 1, 2, 4),
            (0, 3, 1, 4, 2),
            (0, 3, 4, 1, 2),
            (0, 4, 3, 1, 2),
            (1, 2, 0, 3, 4),
            (1, 3, 0, 2, 4),
            (1, 3, 0, 4, 2),
            (2, 0, 1, 3, 4),
            (2, 1, 0, 3, 4),
            (3, 0, 1, 2, 4),
            (3, 0, 1, 4, 2),
            (3, 0, 4, 1, 2),
            (3, 1, 0, 2, 4),
            (3, 1, 0, 4, 2),
            (4, 0, 3, 1, 2),
        },
        [],
    ),
    "groove_connector": (groove_connector, RUNGS_BEFORE_A_BAR, []),
    "clamp_in_path": (clamp_in_path, RUNGS_BEFORE_A_BAR, []),
    "ladder": (
        ladder,
        {(b, r, s, c) for b, c in ((0, 1), (1, 0)) for r, s in ((2, 3), (3, 2))}
        | {(r, b, s, c) for b, c in ((0, 1), (1, 0)) for r, s in ((2, 3), (3, 2))},
        [],
    ),
    "bracket_corner": (t_bracket, {(0, 2, 1), (1, 2, 0)}, []),
    "slide_corridor": (
        corridor,
        {(0, 1, 2, 3), (0, 2, 1, 3), (1, 0, 2, 3), (2, 0, 1, 3)}
        | {(0, 2, 3, 1), (2, 0, 3, 1), (2, 3, 0, 1), (3, 2, 0, 1)},
        [],
    ),
}


REPLAYED_OTHERS = 24
"""Orders outside a hand case's known ones that its test replays."""


SLOW_CASES = {"groove_connector", "clamp_in_path"}
"""The two hand cases of the most MuJoCo replays (~4 s each); their mechanisms keep fast tests
(the groove and clamp-post test below, the rule switches of tests/simulation/test_simulator.py)."""


@pytest.mark.parametrize(
    "name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_CASES else n for n in CASES]
)
def test_hand_case_has_its_known_orders_and_replays(real_sim, world, name):
    make, orders, mechanisms = CASES[name]
    assembly = make(world)
    sample = real_sim.label(assembly)
    assert set(sample.truth.orders()) == orders
    assert sample.info["mechanisms"] == mechanisms
    assert brute_force_truth(real_sim, assembly) == sample.truth
    # Uncached MuJoCo replays: every known order, and a seeded sample of the others (all N! of
    # a 5-part case take seconds each; brute_force_truth above already checked every step).
    others = [o for o in itertools.permutations(range(assembly.n_parts)) if o not in orders]
    picked = np.random.default_rng(0).permutation(len(others))[:REPLAYED_OTHERS]
    for order in [*orders, *(others[i] for i in sorted(picked))]:
        assert (real_sim.replay(assembly, order) is None) == (order in orders), order


def _side_blocks(sim, assembly, placed, part, direction):
    """(rule, body, obstacle, part) of every block on `part`'s side slides along `direction`."""
    verdict = sim.explain(assembly, placed, part)
    motions = sim.motions(assembly)[part]
    return {
        (b.rule, b.body, b.obstacle, b.part)
        for c in verdict.candidates
        if motions[c.motion].kind == "side_slide" and motions[c.motion].direction == direction
        for b in c.blocks
    }


def test_a_cap_closes_the_groove_end_by_the_joint_rule_alone(real_sim, world):
    assembly = capped(world)
    state = 0b10111  # bars, rung 2 and the cap: rung 3 last
    assert not real_sim.explain(assembly, state, 3).feasible
    from_the_capped_end = _side_blocks(real_sim, assembly, state, 3, (-1.0, 0.0))
    assert ("joints", "T-slot connector", "part", 4) in from_the_capped_end
    # The cap's body is not in the way (its clamp's handle, once closed, is for a rung carried
    # in below its top): only the joint rule stops the slide.
    assert {b for b in from_the_capped_end if b[2:] == ("part", 4)} == {
        ("joints", "T-slot connector", "part", 4)
    }
    assert real_sim.explain(assembly, 0b00111, 3).feasible  # without the cap it slides in


def test_a_connector_in_the_groove_and_a_clamp_post_stop_the_side_slide(real_sim, world):
    blocks = _side_blocks(real_sim, groove_connector(world), 0b10111, 3, (-1.0, 0.0))
    assert ("joints", "T-slot connector", "part", 4) in blocks
    assert ("held_part", "slide corridor", "part", 4) in blocks
    # Rung 4's own post stands in its way in from +x, before 4 is placed; 3's post, placed or
    # not, in its way from −x.
    assembly = clamp_in_path(world)
    for state in (0b00111, 0b01111):
        assert ("clamps", "slide corridor", "clamp", 4) in _side_blocks(
            real_sim, assembly, state, 4, (-1.0, 0.0)
        )
        assert ("clamps", "slide corridor", "clamp", 3) in _side_blocks(
            real_sim, assembly, state, 4, (1.0, 0.0)
        )


def test_bracket_grip_decides(real_sim, world):
    """Without finger clearance the bracket could also come last."""
    assembly = t_bracket(world)
    free = real_sim.label(assembly)
    assert "fingers" in free.info["decisive_rules"]
    assert all(o.index(2) == 1 for o in free.truth.orders())


def test_a_profile_without_a_clamp_may_go_first(real_sim, world):
    """The middle stem of a tight comb (13 and 16 mm to its neighbours) has no spot for a clamp
    on either side; fixation lets it go first all the same, the simplification docs/world.md
    states ("Rules"): nothing would hold it while the host slides onto it."""
    p = world.profile
    comb = world.build(p(300, 21, -20), p(200, 74, 30), p(300, 130, -20), p(300, 0, 150, True))
    kinds = [c.kind for c in real_sim.cell.scene(comb).clamps]
    assert kinds == ["toggle", "none", "toggle", "toggle"]
    firsts = {order[0] for order in real_sim.label(comb).truth.orders()}
    assert firsts == {0, 1, 2, 3}
