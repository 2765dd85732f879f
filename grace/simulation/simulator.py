"""The simulator facade: generate a frame, label it with the robot cell (docs/world.md).

Ground truth as the paper's simulator gives it (Sec. IV-A of the paper): every feasible order of
an assembly under the constraints of the robot cell, stored as the reachable-state DAG
(`GroundTruth`). Built by `hydra.utils.instantiate(cfg.simulator)` from
`grace/conf/simulator/{dual_arm,single_arm,boxes}.yaml`, which differ only in the cell's arms.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from grace.domain.assembly import Assembly
from grace.domain.motion import Motion
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.simulation import ground_truth
from grace.simulation.cell_config import CONFIG_DIR, RULES, MotionConfig, typed
from grace.simulation.explain import Verdict, explain
from grace.simulation.generator import StructureGenerator
from grace.simulation.joints import insertion_motions, touching
from grace.simulation.robot_cell import CellPose, RobotCell, Scene


class Simulator:
    """Generates frames and enumerates (with cached cell queries) their feasible orders.

    `cell` is the robot cell's config (kwargs of `RobotCell`) or an already built cell with the
    same interface; `generator` the frame generator's config; `motion` how parts move
    (`MotionConfig`); `rules` switches each rule of docs/world.md on or off (all on by default).
    """

    def __init__(
        self,
        cell: Mapping[str, Any] | RobotCell,
        generator: Mapping[str, Any],
        motion: Mapping[str, Any] | MotionConfig,
        rules: Mapping[str, bool] | None = None,
    ) -> None:
        self.cell = RobotCell(**dict(cell)) if isinstance(cell, Mapping) else cell
        self.motion = typed(MotionConfig, motion, "motion")
        switches = dict(rules or {})
        unknown = set(switches) - set(RULES)
        if unknown:
            raise UserError(
                f"{CONFIG_DIR}: field 'rules' has unknown rules {sorted(unknown)}; "
                f"use {list(RULES)}"
            )
        self.rules = tuple(r for r in RULES if switches.get(r, True))
        self.tolerance = float(self.cell.config.touch_tolerance)
        self.generator = StructureGenerator(tolerance=self.tolerance, **dict(generator))

    def generate(
        self,
        n_parts: int,
        rng: np.random.Generator,
        frame_ok: Callable[[Assembly], bool] | None = None,
    ) -> Assembly:
        """A frame of `n_parts`; a frame built in sections (`generator.section_parts`) takes
        only sections this cell can build in turn (`buildable_piece`) and, if given, that
        leave a frame `frame_ok` accepts as it grows."""
        return self.generator.generate(n_parts, rng, self.buildable_piece, frame_ok)

    def buildable_piece(self, piece: Assembly, head: int) -> bool:
        """Some order of `piece` starts with its part 0 and places its first `head` parts
        before the others (grace/simulation/sections.py)."""
        truth = self.truth(piece, first=0)
        pos = int(np.searchsorted(truth.states, (1 << head) - 1))
        reached = pos < len(truth.states) and truth.states[pos] == (1 << head) - 1
        return truth.feasible and reached and bool(truth.completable[pos] or head == piece.n_parts)

    def carry_heights(self, assembly: Assembly, scene: Scene | None = None) -> list[float]:
        """Heights (mm) a part may be carried in at and lowered from: `approach_clearance` above
        each kind of obstacle (`Scene.carry_heights`); a height is usable while nothing taller
        stands in the cell."""
        scene = scene or self.cell.scene(assembly)
        return scene.carry_heights(self.motion.approach_clearance)

    def motions(self, assembly: Assembly, scene: Scene | None = None) -> list[list[Motion]]:
        """Candidate motions per part (joints.insertion_motions with this config), each from
        every carry height."""
        m = self.motion
        heights = self.carry_heights(assembly, scene)
        return insertion_motions(assembly, m.slide_length, m.slide_lead, heights, self.tolerance)

    def truth(self, assembly: Assembly, first: int | None = None) -> GroundTruth:
        """Every feasible order of `assembly` (those starting with part `first`, if given),
        without the diagnostics of `label`."""
        scene = self.cell.scene(assembly)
        motions = self.motions(assembly, scene)
        options = [self.cell.part_options(scene, p, motions[p]) for p in range(assembly.n_parts)]
        touch = touching(assembly, self.tolerance)
        return ground_truth.orders(assembly, options, touch, self.rules, first)

    def label(self, assembly: Assembly) -> LabelledAssembly:
        """All feasible orders of `assembly` and the diagnostics of ground_truth.label."""
        start = time.perf_counter()
        scene = self.cell.scene(assembly)
        motions = self.motions(assembly, scene)
        options = [self.cell.part_options(scene, p, motions[p]) for p in range(assembly.n_parts)]
        sample = ground_truth.label(
            assembly, options, touching(assembly, self.tolerance), self.rules
        )
        # Clamp bases' footprints (x0, y0, x1, y1 mm) per part, for pictures; [] = no clamp.
        sample.info["clamps"] = [
            [round(float(v), 1) for v in (*c.boxes[0, 0, :2], *c.boxes[0, 1, :2])]
            if len(c.boxes)
            else []
            for c in scene.clamps
        ]
        sample.info["seconds"] = time.perf_counter() - start
        return sample

    def sample(self, n_parts: int, rng: np.random.Generator) -> LabelledAssembly:
        return self.label(self.generate(n_parts, rng))

    def replay(
        self, assembly: Assembly, order: Sequence[int], rules: Sequence[str] | None = None
    ) -> int | None:
        """First failing step of `order` under the cell's uncached MuJoCo checks, None if it
        works (with only `rules` active, default this simulator's)."""
        touch = touching(assembly, self.tolerance)
        active = self.rules if rules is None else tuple(rules)
        return ground_truth.replay(
            assembly, order, self.cell, self.motions(assembly), touch, active
        )

    def replayed_truth(self, assembly: Assembly) -> GroundTruth:
        """The orders `replay` lets through, every one of the N! (`ground_truth.replayed_truth`):
        equal to `label(assembly).truth` when the cached labels are right."""
        touch = touching(assembly, self.tolerance)
        motions = self.motions(assembly)
        return ground_truth.replayed_truth(assembly, self.cell, motions, touch, self.rules)

    def explain(self, assembly: Assembly, placed: int, part: int) -> Verdict:
        """Why `part` can or cannot be placed once the parts of bitmask `placed` are
        (docs/world.md, "Explain"): the deciding rule and, per candidate (arm, IK branch,
        grasp, motion), what blocks it. A few milliseconds: one part's cell queries."""
        motions = self.motions(assembly)
        options = self.cell.placement_options(assembly, part, motions[part])
        fixation = ground_truth.Fixation.of(assembly, touching(assembly, self.tolerance))
        return explain(part, placed, options, motions[part], fixation, self.rules)

    def pose(self, assembly: Assembly, placed: int, part: int) -> CellPose | None:
        """The cell as it places `part` in state `placed` with the option `explain` uses:
        joint angles of every arm, MuJoCo body poses, tool and part boxes (mm), for drawing.
        None if the placement is infeasible."""
        verdict = self.explain(assembly, placed, part)
        used = verdict.used if verdict.feasible else None
        if used is None:
            return None
        motions = self.motions(assembly)
        options = self.cell.placement_options(assembly, part, motions[part])
        option = next(
            o
            for o in options
            if (o.arm, o.branch, o.grasp, o.motion)
            == (used.arm, used.branch, used.grasp, used.motion)
        )
        return self.cell.pose(assembly, placed, part, option)
