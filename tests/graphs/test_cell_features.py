"""The oracle's cell features (model.graph.cell, docs/information-ceiling.md): the simulator's
clamps, the pose on the table and the distance from the arms, which the paper's graph leaves out."""

import dataclasses

import numpy as np
import pytest

from grace.domain.assembly import Assembly, Part
from grace.errors import UserError
from grace.evaluation.input_conflicts import tensors_digest
from grace.graphs.assembly_graph import encode_assembly
from grace.graphs.cell_features import CELL_FEATURES, cell_features
from grace.graphs.encoding import GraphEncoding
from grace.simulation.clamps import clamp_boxes

pytestmark = pytest.mark.numerics  # asserts on float results of numpy arithmetic (.ci/kernels)


def moved(assembly: Assembly, dx: float) -> Assembly:
    """The same assembly `dx` mm further along the table's x axis."""
    parts = []
    for part in assembly.parts:
        pose = part.pose.copy()
        pose[0, 3] += dx
        parts.append(Part(part.name, part.type, pose))
    return Assembly(tuple(parts))


def test_the_oracle_tells_apart_what_the_paper_graph_cannot(samples, default_cell):
    assembly = samples[1].assembly
    there = moved(assembly, 100.0)
    paper, oracle = GraphEncoding(), GraphEncoding(cell=default_cell)
    assert tensors_digest(encode_assembly(assembly, paper)) == tensors_digest(
        encode_assembly(there, paper)
    )  # the paper's graph holds relative geometry only
    assert tensors_digest(encode_assembly(assembly, oracle)) != tensors_digest(
        encode_assembly(there, oracle)
    )
    width = encode_assembly(assembly, oracle).part_static.shape[1]
    assert width == encode_assembly(assembly, paper).part_static.shape[1] + CELL_FEATURES
    assert oracle.extra_part_features == CELL_FEATURES and paper.extra_part_features == 0


def test_features_follow_the_simulators_clamps_and_bases(samples, default_cell):
    assembly = samples[1].assembly
    scale = 100.0
    features = cell_features(assembly, default_cell, scale)
    clamps = clamp_boxes(
        assembly, default_cell.clamp, default_cell.gripper.finger_thickness,
        default_cell.touch_tolerance,
    )  # fmt: skip
    assert features.shape == (assembly.n_parts, CELL_FEATURES)
    assert features[:, 0].tolist() == [float(len(c.boxes) > 0) for c in clamps]
    for row, part, clamp in zip(features, assembly.parts, clamps, strict=True):
        if len(clamp.boxes):
            assert row[1] == clamp.boxes[:, 1, 2].max() / scale
            offset = clamp.boxes[0, :, :2].mean(axis=0) - np.asarray(part.xy)
            assert np.hypot(row[2], row[3]) == pytest.approx(np.hypot(*offset) / scale)
        np.testing.assert_allclose(row[4:6], np.asarray(part.xy) / scale)
        bases = np.array([b[:2] for b in default_cell.bases], dtype=float)
        np.testing.assert_allclose(row[8:], np.linalg.norm(bases - part.xy, axis=1) / scale)


def test_more_arms_than_the_features_hold_is_refused(samples, default_cell):
    three = dataclasses.replace(default_cell, bases=[*default_cell.bases, [0, 600, 420, 90]])
    with pytest.raises(UserError, match=r"model\.graph\.cell"):
        cell_features(samples[1].assembly, three, 100.0)
