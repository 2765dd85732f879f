import numpy as np

from grace.domain.assembly import (
    Assembly,
    Part,
    PartType,
    SurfaceType,
    canonical_order,
    planar_pose,
)


def test_profile_surfaces_clockwise_from_top():
    p = Part("p", PartType.PROFILE_200, planar_pose(0, 0))
    s = p.surfaces(0)
    assert [x.normal for x in s] == [(0, 1), (1, 0), (0, -1), (-1, 0)]
    assert [x.type for x in s] == [SurfaceType.P200_SHORT, SurfaceType.P200_LONG] * 2
    assert s[0].center == (0.0, 100.0)


def test_relations_t_joint():
    bar = Part("bar", PartType.PROFILE_300, planar_pose(0, 0, 1))  # along x, y in [-20, 20]
    stem = Part("stem", PartType.PROFILE_200, planar_pose(0, 120))  # end at y=20 touches bar
    a = Assembly((bar, stem))
    r = a.relations
    assert r.shape == (8, 8)
    assert np.all(np.diag(r) == 0)
    assert r[0, 1] == 1  # same part
    names = a.surface_names()
    i = names.index("bar_surface_4")  # rotated +90°: local -x side faces -y... check normals
    assert a.surfaces()[i].normal == (0, -1)
    j = names.index("bar_surface_2")  # faces +y, touches the stem's bottom end
    k = names.index("stem_surface_3")
    assert r[j, k] == 0 and r[k, j] == 0
    assert r[j, names.index("stem_surface_2")] == -1


def test_canonical_order_by_distance():
    far = Part("far", PartType.PROFILE_200, planar_pose(500, 0))
    near = Part("near", PartType.PROFILE_200, planar_pose(100, 0))
    assert [p.name for p in canonical_order([far, near])] == ["near", "far"]
