"""The dual-arm robot cell: reach and clearance of one placement (issue 2, rules 1 and 2).

A placement option is (arm, grasp, motion). Its arm is reachable if the closed-form IK
(`kinematics.IiwaArm`) holds the grasp at every TCP sample along the motion within joint limits,
with the arm's links free of the table and of each other. Its blockers are the other parts that the
swept fingers, palm and held part (`clearance.swept_boxes`) or the arm links at those samples
penetrate deeper than the touching tolerance, found with MuJoCo's collision detection.

`placement_options` puts every other part of the assembly in the scene at once and attributes each
contact to its part, so one query per option yields the blocker set for every state: placing the
part is collision-free in state S iff `blockers & S == 0`. `check_placement` is the uncached
reference that builds the scene of one state.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from grace.domain.assembly import Assembly, mask_to_parts
from grace.domain.motion import Motion
from grace.simulation import mjcf
from grace.simulation.cell_config import CONFIG_FILE, CellConfig
from grace.simulation.clearance import (
    Grasp,
    grasp_candidates,
    part_boxes,
    swept_boxes,
    tcp_samples,
)
from grace.simulation.kinematics import IiwaArm

_PARKED_HALF = 1e-3
"""Half size (m) of a parked slot box."""


@dataclass(frozen=True)
class PlacementOption:
    """One (arm, grasp, motion) way to place a part; indices into the arms, the part's grasp
    candidates and the motions passed in.

    `blockers` is the bitmask of other parts penetrated along the motion. For an unreachable
    option it covers the swept gripper and held part only (there is no arm pose to test).
    """

    arm: int
    grasp: int
    motion: int
    reachable: bool
    blockers: int


class RobotCell:
    """Two iiwa arms with parallel grippers beside a table, compiled once into MuJoCo."""

    def __init__(self, **cell_cfg) -> None:
        self.config = CellConfig.parse(cell_cfg)
        self.model = mujoco.MjModel.from_xml_string(mjcf.build_cell_xml(self.config))
        self.data = mujoco.MjData(self.model)
        cfg = self.config
        tool = (cfg.gripper.palm_height + cfg.gripper.finger_length) * mjcf.MM
        self.arms = [
            IiwaArm(
                lengths=tuple(x * mjcf.MM for x in cfg.arm.link_lengths),
                limits=np.radians(cfg.arm.joint_limits),
                base=np.array(base[:3]) * mjcf.MM,
                base_yaw=float(np.radians(base[3])),
                tool_length=tool,
            )
            for base in cfg.bases
        ]
        name = self.model.geom
        self._part_geoms = np.array([name(f"part{i}").id for i in range(mjcf.part_slot_count(cfg))])
        self._sweep_geoms = np.array(
            [name(f"sweep{i}").id for i in range(mjcf.sweep_slot_count(cfg))]
        )
        self._qpos = [
            np.array([self.model.joint(f"arm{a}_a{k}").qposadr[0] for k in range(1, 8)])
            for a in range(len(self.arms))
        ]
        # Owner of every geom: part slot index, or a tag for the table, sweeps and arms.
        self._slot_of = np.full(self.model.ngeom, -1)
        self._slot_of[self._part_geoms] = np.arange(len(self._part_geoms))
        self._arm_of = np.full(self.model.ngeom, -1)
        for a in range(len(self.arms)):
            for link in ("column", "upper", "forearm", "wrist"):
                self._arm_of[name(f"arm{a}_{link}").id] = a
        self._table = name("table").id
        self._slot_part = np.full(len(self._part_geoms), -1)
        self._tolerance = cfg.touch_tolerance * mjcf.MM
        self._parked = {
            kind: np.array([mjcf.park_position(kind, k) for k in range(len(geoms))])
            for kind, geoms in ((0, self._part_geoms), (1, self._sweep_geoms))
        }
        self._park(self._part_geoms, 0)
        self._park(self._sweep_geoms, 1)

    @property
    def n_arms(self) -> int:
        return len(self.arms)

    def grasps(self, assembly: Assembly, part: int) -> list[Grasp]:
        """The grasp candidates of a part, in the order `PlacementOption.grasp` indexes."""
        return grasp_candidates(
            assembly.parts[part], self.config.gripper, self.config.grasp_fractions
        )

    def placement_options(
        self, assembly: Assembly, part: int, motions: list[Motion]
    ) -> list[PlacementOption]:
        """Every (arm, grasp, motion) option of `part` with all other parts in the scene."""
        others = [i for i in range(assembly.n_parts) if i != part]
        self._load_parts(assembly, others)
        return [
            PlacementOption(arm, g, m, reachable, blockers)
            for g, grasp in enumerate(self.grasps(assembly, part))
            for m, motion in enumerate(motions)
            for arm, (reachable, blockers) in enumerate(self._query(assembly, part, grasp, motion))
        ]

    def check_placement(self, assembly: Assembly, part: int, placed: int, motion: Motion) -> bool:
        """Reference check: only the parts of `placed` in the scene; True if some arm and grasp
        reach the part along `motion` without penetrating any of them."""
        self._load_parts(assembly, [i for i in mask_to_parts(placed) if i != part])
        return any(
            reachable and blockers == 0
            for grasp in self.grasps(assembly, part)
            for reachable, blockers in self._query(assembly, part, grasp, motion)
        )

    # Scene handling -------------------------------------------------------------------------

    def _load_parts(self, assembly: Assembly, parts: list[int]) -> None:
        if assembly.n_parts > self.config.max_parts:
            raise ValueError(
                f"{CONFIG_FILE}: field 'max_parts' = {self.config.max_parts} is too small for "
                f"assembly '{assembly.name}' of {assembly.n_parts} parts; raise it"
            )
        boxes, owners = [], []
        for i in parts:
            for box in part_boxes(assembly.parts[i]):
                boxes.append(box)
                owners.append(i)
        self._place(self._part_geoms, np.array(boxes).reshape(-1, 2, 3), 0)
        self._slot_part[:] = -1
        self._slot_part[: len(owners)] = owners

    def _place(self, geoms: np.ndarray, boxes: np.ndarray, kind: int) -> None:
        """Move the first len(boxes) geoms of a pool onto `boxes` (mm) and park the rest."""
        n = len(boxes)
        used = geoms[:n]
        half = (boxes[:, 1] - boxes[:, 0]) / 2 * mjcf.MM
        self.model.geom_pos[used] = (boxes[:, 0] + boxes[:, 1]) / 2 * mjcf.MM
        self.model.geom_size[used] = half
        self.model.geom_rbound[used] = np.linalg.norm(half, axis=1)
        self.model.geom_aabb[used, 3:] = half
        self._park(geoms[n:], kind, start=n)

    def _park(self, geoms: np.ndarray, kind: int, start: int = 0) -> None:
        self.model.geom_pos[geoms] = self._parked[kind][start:]
        self.model.geom_size[geoms] = _PARKED_HALF
        self.model.geom_rbound[geoms] = np.sqrt(3) * _PARKED_HALF
        self.model.geom_aabb[geoms, :3] = 0.0
        self.model.geom_aabb[geoms, 3:] = _PARKED_HALF

    # Queries -------------------------------------------------------------------------------

    def _query(
        self, assembly: Assembly, part: int, grasp: Grasp, motion: Motion
    ) -> list[tuple[bool, int]]:
        """(reachable, blockers) per arm for one grasp and motion, scene already loaded."""
        cfg = self.config
        if len(motion.waypoints) - 1 > cfg.max_segments:
            raise ValueError(
                f"{CONFIG_FILE}: field 'max_segments' = {cfg.max_segments} is below the "
                f"{len(motion.waypoints) - 1} segments of a '{motion.kind}' motion; raise it"
            )
        solid = np.concatenate([part_boxes(assembly.parts[part]), grasp.gripper_boxes(cfg.gripper)])
        self._place(self._sweep_geoms, swept_boxes(solid, motion), 1)
        for a in range(self.n_arms):
            self.data.qpos[self._qpos[a]] = 0.0
        swept = self._collide()[0]
        self.model.geom_contype[self._sweep_geoms] = 0
        self.model.geom_conaffinity[self._sweep_geoms] = 0
        tcp = tcp_samples(grasp.tcp, motion, cfg.arm_sample_step) * mjcf.MM
        results = [self._arm_query(a, tcp, grasp.yaw, swept) for a in range(self.n_arms)]
        self.model.geom_contype[self._sweep_geoms] = mjcf.SWEEP_BIT
        self.model.geom_conaffinity[self._sweep_geoms] = mjcf.PART_BIT
        return results

    def _arm_query(self, arm: int, tcp: np.ndarray, yaw: float, swept: int) -> tuple[bool, int]:
        """First IK branch within limits whose links stay clear of table and themselves."""
        kin = self.arms[arm]
        if not kin.within_reach(tcp).all():
            return False, swept
        q, ok = kin.top_down_ik(tcp, yaw)
        adr = self._qpos[arm]
        for branch in np.flatnonzero(ok.all(axis=1)):
            blockers, clear = swept, True
            for sample in q[branch]:
                self.data.qpos[adr] = sample
                hits, bad = self._collide(arm)
                if bad:
                    clear = False
                    break
                blockers |= hits
            self.data.qpos[adr] = 0.0
            if clear:
                return True, blockers
        return False, swept

    def _collide(self, arm: int = -1) -> tuple[int, bool]:
        """Run MuJoCo collision; returns (parts penetrated, whether `arm` hit table or itself)."""
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_collision(self.model, self.data)
        ncon = self.data.ncon
        if ncon == 0:
            return 0, False
        contact = self.data.contact
        deep = contact.dist[:ncon] < -self._tolerance
        blockers, bad = 0, False
        for g1, g2 in contact.geom[:ncon][deep]:
            slot = max(self._slot_of[g1], self._slot_of[g2])
            owner = max(self._arm_of[g1], self._arm_of[g2])
            if slot >= 0:
                if owner in (-1, arm):
                    blockers |= 1 << int(self._slot_part[slot])
            elif owner == arm and arm >= 0:
                bad = True
        return blockers, bad
