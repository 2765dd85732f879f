import numpy as np

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.graphs.assembly_graph import PAIR_EDGE, assembly_graph
from grace.graphs.pair_geometry import PAIR_GEOMETRY_FEATURES, pair_geometry


def corner(dx: float = 0.0, dy: float = 0.0, turns: int = 0) -> Assembly:
    """A 200 mm post along y at the origin and a 300 mm bar along x whose end touches the post's
    top-right corner, the whole frame moved by (dx, dy) and turned by `turns` quarter turns."""
    rot = planar_pose(0.0, 0.0, turns)
    move = planar_pose(dx, dy)
    return Assembly(
        (
            Part("post", PartType.PROFILE_200, move @ rot @ planar_pose(0.0, 0.0, 0)),
            Part("bar", PartType.PROFILE_300, move @ rot @ planar_pose(170.0, 120.0, 1)),
        )
    )


def test_each_part_is_read_in_the_other_parts_frame():
    g = pair_geometry(corner(), scale=100.0)
    assert g.shape == (2, 2, PAIR_GEOMETRY_FEATURES)
    assert not g[0, 0].any() and not g[1, 1].any()
    bar_from_post = g[1, 0]
    # The bar covers x 20..320, y 100..140 in the post's frame; it touches the post's box
    # (x −20..20, y −100..100) at a corner: both gaps 0.
    np.testing.assert_allclose(bar_from_post[:6], [0.2, 1.0, 3.2, 1.4, 0.0, 0.0], atol=1e-12)
    assert bar_from_post[6:10].tolist() == [0, 1, 0, 0]  # a quarter turn against the post
    assert bar_from_post[10:13].tolist() == [0, 1, 0]  # it is a 300 mm profile
    assert bar_from_post[13:16].tolist() == [1, 0, 0]  # seen from a 200 mm profile
    post_from_bar = g[0, 1]
    # In the bar's frame (its local y along world +x): local x = world y − 120,
    # local y = −(world x − 170).
    np.testing.assert_allclose(post_from_bar[:6], [-2.2, 1.5, -0.2, 1.9, 0.0, 0.0], atol=1e-12)
    assert post_from_bar[6:10].tolist() == [0, 0, 0, 1]


def test_gaps_are_positive_apart_and_negative_overlapping():
    a = Assembly(
        (
            Part("left", PartType.PROFILE_200, planar_pose(0.0, 0.0)),
            Part("right", PartType.PROFILE_200, planar_pose(48.0, 50.0)),
        )
    )
    gaps = pair_geometry(a, scale=1.0)[1, 0, 4:6]
    # 8 mm between the long sides (x), overlapping 150 mm along the length (y).
    np.testing.assert_allclose(gaps, [8.0, -150.0], atol=1e-9)


def test_moving_or_turning_the_whole_assembly_changes_nothing():
    reference = pair_geometry(corner(), scale=100.0)
    for dx, dy, turns in [(250.0, -75.0, 0), (0.0, 0.0, 1), (-40.0, 310.0, 3)]:
        np.testing.assert_allclose(
            pair_geometry(corner(dx, dy, turns), scale=100.0), reference, atol=1e-9
        )


def test_state_graph_carries_every_ordered_pair_once():
    g = assembly_graph(corner(), state=0b01)
    assert g[PAIR_EDGE].edge_index.tolist() == [[0, 1], [1, 0]]
    np.testing.assert_allclose(
        g[PAIR_EDGE].edge_attr.numpy(),
        pair_geometry(corner(), scale=100.0)[[0, 1], [1, 0]],
        atol=1e-6,
    )
