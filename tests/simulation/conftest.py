"""Shared fixtures: a coordinate-level fake robot cell and hand-built assemblies.

Tests reach the helpers through the `world` fixture (never `import conftest`: the root conftest
shares the module name).

The fake has the RobotCell interface (placement_options / check_placement) with planar geometry:
two fingers beside a profile at each grasp point, the held part and fingers swept along the motion,
reach as a distance to either arm base. It is a stand-in for fast logic tests, not the physics.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pytest
from omegaconf import OmegaConf

from grace import CONF_DIR
from grace.domain.assembly import PROFILE_SECTION_MM, Assembly, Part, PartType, planar_pose
from grace.domain.motion import Motion
from grace.simulation.joints import Box, boxes_overlap
from grace.simulation.simulator import Simulator

CONFIG = CONF_DIR / "simulator" / "dual_arm.yaml"
HALF = PROFILE_SECTION_MM / 2


@dataclass(frozen=True)
class FakeOption:
    arm: int
    grasp: int
    motion: int
    reachable: bool
    blockers: int


class FakeCell:
    """Planar stand-in for RobotCell: fingers `finger_mm` wide beside profiles, circular reach."""

    def __init__(
        self,
        finger_mm: float = 12.0,
        finger_length: float = 20.0,
        grasps: tuple[float, ...] = (-0.25, 0.0, 0.25),
        bases: tuple[tuple[float, float], ...] = ((-550.0, 0.0), (550.0, 0.0)),
        reach_mm: float = 820.0,
        tolerance: float = 0.5,
    ) -> None:
        self.finger_mm, self.finger_length = finger_mm, finger_length
        self.grasps, self.bases, self.reach, self.tol = grasps, bases, reach_mm, tolerance

    def _grasp_boxes(self, part: Part, g: float) -> tuple[np.ndarray, list[Box]]:
        rot, origin = part.pose[:2, :2], part.pose[:2, 3]
        if not part.type.is_profile:
            return origin.copy(), []
        y = g * part.type.length
        w, f = self.finger_length / 2, self.finger_mm
        local = [(HALF, y - w, HALF + f, y + w), (-HALF - f, y - w, -HALF, y + w)]
        boxes = []
        for x0, y0, x1, y1 in local:
            c = np.array([[x0, y0], [x1, y1]]) @ rot.T + origin
            lo, hi = c.min(axis=0), c.max(axis=0)
            boxes.append((lo[0], lo[1], hi[0], hi[1]))
        return rot @ np.array([0.0, y]) + origin, boxes

    @staticmethod
    def _swept(box: Box, motion: Motion) -> Box:
        start = np.asarray(motion.waypoints[0][:2])
        lo = np.minimum(start, 0.0)
        hi = np.maximum(start, 0.0)
        return (box[0] + lo[0], box[1] + lo[1], box[2] + hi[0], box[3] + hi[1])

    def _options(self, assembly: Assembly, part: int, motions: list[Motion], others: list[int]):
        p = assembly.parts[part]
        grasps = self.grasps if p.type.is_profile else (0.0,)
        for m_i, motion in enumerate(motions):
            for g_i, g in enumerate(grasps):
                point, fingers = self._grasp_boxes(p, g)
                swept = [self._swept(b, motion) for b in [*p.footprint_boxes(), *fingers]]
                blockers = 0
                for j in others:
                    if any(
                        boxes_overlap(s, b, self.tol)
                        for s in swept
                        for b in assembly.parts[j].footprint_boxes()
                    ):
                        blockers |= 1 << j
                start = point + np.asarray(motion.waypoints[0][:2])
                for a, base in enumerate(self.bases):
                    reach = max(np.hypot(*(point - base)), np.hypot(*(start - base)))
                    yield FakeOption(a, g_i, m_i, bool(reach <= self.reach), blockers)

    def placement_options(self, assembly: Assembly, part: int, motions: list[Motion]):
        others = [j for j in range(assembly.n_parts) if j != part]
        return list(self._options(assembly, part, motions, others))

    def check_placement(self, assembly: Assembly, part: int, placed: int, motion: Motion) -> bool:
        others = [j for j in range(assembly.n_parts) if placed >> j & 1]
        return any(
            o.reachable and not o.blockers for o in self._options(assembly, part, [motion], others)
        )


def profile(length: int, x: float, y: float, along_x: bool = False) -> Part:
    kind = PartType.PROFILE_300 if length == 300 else PartType.PROFILE_200
    return Part("p", kind, planar_pose(x, y, 1 if along_x else 0))


def bracket(x: float, y: float, quarter_turns: int = 0) -> Part:
    return Part("b", PartType.BRACKET, planar_pose(x, y, quarter_turns))


def build(*parts: Part) -> Assembly:
    return Assembly(tuple(Part(f"part_{i + 1}", p.type, p.pose) for i, p in enumerate(parts)))


@pytest.fixture(scope="session")
def world() -> SimpleNamespace:
    """Builders for hand-made assemblies and the fake cell class."""
    return SimpleNamespace(profile=profile, bracket=bracket, build=build, FakeCell=FakeCell)


@pytest.fixture(scope="session")
def sim_cfg():
    return OmegaConf.to_container(OmegaConf.load(CONFIG), resolve=False)


@pytest.fixture
def fake_sim(sim_cfg) -> Simulator:
    return Simulator(
        generator=sim_cfg["generator"],
        cell=FakeCell(),
        finger_mm=12.0,
        slide_length=sim_cfg["slide_length"],
        approach_height=sim_cfg["approach_height"],
        touch_tolerance=0.5,
    )
