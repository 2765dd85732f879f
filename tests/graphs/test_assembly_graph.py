import numpy as np
import pytest
import torch

from grace.domain.assembly import Assembly, Part, PartType, SurfaceType, planar_pose
from grace.graphs.assembly_graph import (
    PART_EDGE,
    SURFACE_EDGE,
    assembly_graph,
    encode_assembly,
    scaled_relations,
)
from grace.graphs.encoding import GraphEncoding, sinusoidal_pe

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)


def frame() -> Assembly:
    """A 300 mm bar, a 200 mm post standing on it, a bracket in their corner."""
    return Assembly(
        (
            Part("bar", PartType.PROFILE_300, planar_pose(0.0, 0.0, 1)),
            Part("post", PartType.PROFILE_200, planar_pose(0.0, 120.0)),
            Part("bracket", PartType.BRACKET, planar_pose(20.0, 20.0)),
        )
    )


def test_node_features_per_spec():
    g = assembly_graph(frame(), state=0b101)
    assert g["part"].x.shape == (3, 18)
    assert g["surface"].x.shape == (10, 17)
    assert g["part"].x[:, 0].tolist() == [1.0, 0.0, 1.0]
    assert g["part"].x[:, 1].tolist() == [PartType.PROFILE_300.index, PartType.PROFILE_200.index, 2]
    np.testing.assert_allclose(g["part"].x[:, 2:], sinusoidal_pe(np.arange(3), 16), atol=1e-6)
    t = SurfaceType
    long3, short3, long2, short2 = t.P300_LONG, t.P300_SHORT, t.P200_LONG, t.P200_SHORT
    assert g["surface"].x[:, 0].tolist() == [
        *(short3, long3, short3, long3),
        *(short2, long2, short2, long2),
        *(t.BRACKET_LATERAL, t.BRACKET_LATERAL),
    ]
    surface_ids = [1, 2, 3, 4, 1, 2, 3, 4, 1, 2]
    np.testing.assert_allclose(g["surface"].x[:, 1:], sinusoidal_pe(surface_ids, 16), atol=1e-6)


def test_part_pe_none_blanks_part_ids_only():
    g = assembly_graph(frame(), state=0, enc=GraphEncoding(part_pe="none"))
    assert not g["part"].x[:, 2:].any()
    surface_ids = [1, 2, 3, 4, 1, 2, 3, 4, 1, 2]
    np.testing.assert_allclose(g["surface"].x[:, 1:], sinusoidal_pe(surface_ids, 16), atol=1e-6)


def test_edges_per_spec():
    a = frame()
    g = assembly_graph(a, state=0)
    src, dst = g[SURFACE_EDGE].edge_index
    assert len(src) == 100 and set(zip(src.tolist(), dst.tolist(), strict=True)) == {
        (i, j) for i in range(10) for j in range(10)
    }
    rel = scaled_relations(a, 100.0)
    np.testing.assert_allclose(g[SURFACE_EDGE].edge_attr[:, 0], rel[src, dst], atol=1e-6)
    assert g[PART_EDGE].edge_index.tolist() == [list(range(10)), [0] * 4 + [1] * 4 + [2] * 2]


def test_relation_codes_and_distance_scale():
    a = frame()
    rel = scaled_relations(a, 100.0)
    raw = np.asarray(a.relations)
    assert np.all(np.diag(rel) == 0)
    assert rel[0, 1] == 1.0 and rel[4, 5] == 1.0  # same part
    assert rel[0, 4] == -1.0  # bar end (normal ±y... rotated) vs post end: orthogonal
    parallel = (raw != 1) & (raw != -1) & ~np.eye(10, dtype=bool)
    parallel[:4, :4] = parallel[4:8, 4:8] = parallel[8:, 8:] = False
    assert parallel.any()
    np.testing.assert_allclose(rel[parallel], raw[parallel] / 100.0)
    np.testing.assert_allclose(scaled_relations(a, 1.0)[parallel], raw[parallel])


def test_graph_is_a_pure_function_of_assembly_and_state():
    g1, g2 = assembly_graph(frame(), 0b011), assembly_graph(frame(), 0b011)
    for key in ("part", "surface"):
        assert torch.equal(g1[key].x, g2[key].x)
    assert torch.equal(g1[SURFACE_EDGE].edge_attr, g2[SURFACE_EDGE].edge_attr)


def test_permutation_changes_ids_not_the_graph():
    a = frame()
    plain = encode_assembly(a, GraphEncoding())
    enc = GraphEncoding(permute_parts="test", permute_surfaces="test")
    rng = np.random.default_rng(1)
    perm = encode_assembly(a, enc, training=False, rng=rng)
    while torch.equal(plain.part_static, perm.part_static):  # an identity draw: draw again
        perm = encode_assembly(a, enc, training=False, rng=rng)
    assert torch.equal(plain.relation, perm.relation)
    assert torch.equal(plain.surface_part, perm.surface_part)
    assert torch.equal(plain.part_static[:, 0], perm.part_static[:, 0])  # part types stay
    assert torch.equal(plain.surface_x[:, 0], perm.surface_x[:, 0])  # surface types stay
    rows = {tuple(r) for r in plain.part_static[:, 1:].tolist()}
    assert rows == {tuple(r) for r in perm.part_static[:, 1:].tolist()}  # same PEs, reassigned


@pytest.mark.parametrize("pe", ["random", "none"])
def test_pe_variants_keep_shapes(pe):
    t = encode_assembly(frame(), GraphEncoding(pe=pe), rng=np.random.default_rng(0))
    assert t.part_static.shape == (3, 17) and t.surface_x.shape == (10, 17)
    assert (t.part_static[:, 1:].abs().sum() == 0) == (pe == "none")
