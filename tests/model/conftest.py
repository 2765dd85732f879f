"""Small labelled assemblies for model tests: FakeSimulator rows plus a frame with a bracket."""

from __future__ import annotations

import numpy as np
import pytest
from hydra.utils import instantiate

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly


def bracket_frame() -> LabelledAssembly:
    """Bar, post and a bracket in their corner; the bracket needs both profiles placed."""
    assembly = Assembly(
        (
            Part("bar", PartType.PROFILE_300, planar_pose(0.0, 0.0, 1)),
            Part("post", PartType.PROFILE_200, planar_pose(0.0, 120.0)),
            Part("bracket", PartType.BRACKET, planar_pose(20.0, 20.0)),
        )
    )
    truth = GroundTruth.explore(3, lambda state, part: part != 2 or state == 0b011)
    return LabelledAssembly(assembly, truth)


@pytest.fixture
def samples(fake_simulator) -> list[LabelledAssembly]:
    """The bracket frame, five feasible rows of 3–6 parts and one infeasible row."""
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(0)
    drawn = [simulator.sample(n, rng) for n in (3, 4, 5, 6) * 8]
    feasible = [s for s in drawn if s.truth.feasible and s.size > 3][:5]
    infeasible = [s for s in drawn if not s.truth.feasible][:1]
    return [bracket_frame(), *feasible, *infeasible]
