"""The simulator facade: generate a structure, label it with the robot cell (issue 2).

Ground truth as SPEC §1 asks of the original simulator: every feasible order of an assembly under
the constraints of a dual-arm cell, stored as the reachable-state DAG (`GroundTruth`).

Built by `hydra.utils.instantiate(cfg.simulator)` from `grace/conf/simulator/dual_arm.yaml`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from grace.domain.assembly import Assembly
from grace.domain.motion import Motion
from grace.domain.sample import LabelledAssembly
from grace.simulation import feasibility
from grace.simulation.generator import StructureGenerator
from grace.simulation.joints import insertion_motions, touching
from grace.simulation.robot_cell import RobotCell


class Simulator:
    """Generates assemblies and brute-forces (with caching) their feasible orders.

    `cell` is the robot cell's config (kwargs of `RobotCell`) or an already built cell with the
    same interface (tests pass a fake). `finger_mm` is the gap a gripper finger needs, used to draw
    rail gaps on either side of it; `slide_length` the T-slot slide stretch, `approach_height`
    the height a part is lowered from, `touch_tolerance` the face distance that still counts as
    contact (all mm).
    """

    def __init__(
        self,
        generator: Mapping[str, Any],
        cell: Mapping[str, Any] | feasibility.Cell,
        finger_mm: float,
        slide_length: float,
        approach_height: float,
        touch_tolerance: float,
    ) -> None:
        self.cell = RobotCell(**dict(cell)) if isinstance(cell, Mapping) else cell
        self.slide_length = float(slide_length)
        self.approach_height = float(approach_height)
        self.touch_tolerance = float(touch_tolerance)
        self.generator = StructureGenerator(
            finger_mm=finger_mm, tolerance=self.touch_tolerance, **dict(generator)
        )

    def generate(self, n_parts: int, rng: np.random.Generator) -> Assembly:
        return self.generator.generate(n_parts, rng)

    def motions(self, assembly: Assembly) -> list[list[Motion]]:
        """Candidate insertion motions per part (joints.insertion_motions with this config)."""
        return insertion_motions(
            assembly, self.slide_length, self.approach_height, self.touch_tolerance
        )

    def label(self, assembly: Assembly) -> LabelledAssembly:
        """All feasible orders of `assembly` and the diagnostics of feasibility.label."""
        start = time.perf_counter()
        touch = touching(assembly, self.touch_tolerance)
        sample = feasibility.label(assembly, self.cell, self.motions(assembly), touch)
        sample.info["seconds"] = time.perf_counter() - start
        return sample

    def sample(self, n_parts: int, rng: np.random.Generator) -> LabelledAssembly:
        return self.label(self.generate(n_parts, rng))

    def replay(self, assembly: Assembly, order: Sequence[int]) -> int | None:
        """First failing step of `order` under the robot's uncached checks, None if it works."""
        touch = touching(assembly, self.touch_tolerance)
        return feasibility.replay(assembly, order, self.cell, self.motions(assembly), touch)
