"""The robot cell: what stands in the way of one placement (docs/world.md, "The cell").

A placement option is (arm, IK branch, grasp, motion). It is `reachable` if the closed-form IK
(`kinematics.IiwaArm`) holds the grasp at every TCP sample along the motion within the joint
limits, `arm_clear` if the arm's links then stay clear of the table and of each other. Its
blocker masks say which other parts stop it, one mask per (robot body, obstacle kind):

- bodies: the motion's T-slot joints (`joint`), the two fingers, the palm (gripper body), the
  held part, and the four arm links (column, upper arm, forearm, wrist);
- obstacle kinds: the part itself, its clamp's arm (there once the part is placed), or its
  clamp's post (`clamps.clamp_boxes`), which stands on the plate from the start: a post hit
  makes an option unusable in every state, also for the post's own profile.

The fingers, palm and held part are world-aligned boxes moving along world axes, so the volume
each sweeps along a motion segment is exactly the box spanning its start and end copies; their
contacts are box overlaps. The arm links are capsules in arbitrary poses: a box test on their
bounds picks the samples where they may touch something, and MuJoCo's collision detection
decides those. `options` puts every part of the assembly into the scene at once and attributes
each contact to its owner, so one query per option gives the blockers for every state: the
option is free in state S iff it hits no post and `blockers & S == 0` for the other masks.
`check_placement` is the uncached reference: only the parts of one state (and every post) in
MuJoCo, tool and arm sampled every few millimetres.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from grace.domain.assembly import Assembly, mask_to_parts
from grace.domain.motion import Motion
from grace.errors import UserError
from grace.simulation import mjcf
from grace.simulation.cell_config import CONFIG_DIR, RULES, CellConfig, check_cell, typed
from grace.simulation.clamps import clamp_boxes
from grace.simulation.clearance import (
    Grasp,
    grasp_candidates,
    part_boxes,
    swept_boxes,
    tcp_samples,
)
from grace.simulation.kinematics import IiwaArm

BODIES = ("joint", "finger", "palm", "held_part", *(f"arm_{link}" for link in mjcf.LINKS))
KINDS = ("part", "clamp", "post")
RULE_OF_BODY = {
    "joint": "joints",
    "finger": "fingers",
    "palm": "palm",
    "held_part": "held_part",
    **{f"arm_{link}": "arm_links" for link in mjcf.LINKS},
}
N_CATEGORIES = len(BODIES) * len(KINDS)
_FINGER, _PALM, _HELD = 1, 2, 3
_ARM0 = 4
REFERENCE_STEP_MM = 4.0
"""TCP step of the reference check; thinner than any part (a bracket wall is 8 mm)."""
_PARKED_HALF = 1e-3


def category(body: str, kind: str) -> int:
    """Column of (body, obstacle kind) in `PlacementOption.masks`."""
    return BODIES.index(body) * len(KINDS) + KINDS.index(kind)


@dataclass(frozen=True)
class PlacementOption:
    """One way to place a part; `arm` = −1 in a cell without robot, `branch` = −1 if no IK
    branch reaches. `masks[category(body, kind)]` is the bitmask of parts whose body, clamp arm
    or clamp post that robot body would penetrate (for an unreachable option only the tool and
    the joint); a post is there in every state, the rest once its part is placed."""

    arm: int
    branch: int
    grasp: int
    motion: int
    reachable: bool
    arm_clear: bool
    masks: tuple[int, ...]

    @property
    def posts(self) -> int:
        """Bitmask of the profiles whose clamp post any robot body would hit."""
        out = 0
        for body in BODIES:
            out |= self.masks[category(body, "post")]
        return out

    @property
    def blockers(self) -> int:
        """Bitmask of the parts whose body or clamp arm would stop this option once placed."""
        out = 0
        for c, m in enumerate(self.masks):
            if KINDS[c % len(KINDS)] != "post":
                out |= m
        return out

    def free(self, placed: int) -> bool:
        """Usable with every rule on once the parts of bitmask `placed` are placed."""
        return self.reachable and self.arm_clear and not self.posts and not self.blockers & placed


@dataclass
class Scene:
    """One assembly's obstacles: every part's boxes and its clamp's, with owner and kind
    (0 part, 1 clamp); `fixed` marks the clamp posts, which stand from the start."""

    assembly: Assembly
    clamps: list[np.ndarray]
    lo: np.ndarray
    hi: np.ndarray
    owner: np.ndarray
    kind: np.ndarray
    fixed: np.ndarray
    bits: np.ndarray = field(init=False)
    column: np.ndarray = field(init=False)
    """Per box, its obstacle kind's index in `KINDS` (part, clamp arm, post)."""

    def __post_init__(self) -> None:
        self.bits = np.left_shift(np.int64(1), self.owner.astype(np.int64))
        self.column = np.where(self.fixed, KINDS.index("post"), self.kind)

    def present(self, parts: list[int], clamps: bool = True) -> np.ndarray:
        """Which boxes stand in the cell once `parts` are placed: theirs, and with clamps their
        clamps' arms and every post."""
        placed = np.isin(self.owner, parts)
        return (placed & (self.kind == 0)) | (clamps & ((placed & (self.kind == 1)) | self.fixed))

    def boxes_of(self, parts: list[int], clamps: bool = True) -> np.ndarray:
        """World boxes (k×2×3, mm) of `parts` and, if asked, their clamps."""
        keep = np.isin(self.owner, parts) & ((self.kind == 0) | clamps)
        return np.stack([self.lo[keep], self.hi[keep]], axis=1)

    def posts(self) -> np.ndarray:
        """Every clamp post (k×2×3, mm): on the plate before any part arrives."""
        return np.stack([self.lo[self.fixed], self.hi[self.fixed]], axis=1)

    def obstacles_for(self, part: int) -> np.ndarray:
        """Boxes that can stop `part`: everything but its own body and clamp arm."""
        return (self.owner != part) | self.fixed


@dataclass(frozen=True)
class CellPose:
    """The cell drawn at one step: what `RobotCell.pose` returns (docs/world.md, "Explain")."""

    joint_angles: dict[int, np.ndarray]
    """Per arm, A1…A7 in radians (the arm that places at its final pose, the others at home)."""
    bodies: dict[str, tuple[np.ndarray, np.ndarray]]
    """MuJoCo body name → (position in mm, 3×3 rotation) in the world frame."""
    tool: np.ndarray
    """Fingers, palm and held part at the final pose: k×2×3 world boxes in mm."""
    parts: dict[int, np.ndarray]
    """Placed part index (the placed part included) → its boxes and its clamp's, k×2×3 mm."""
    posts: np.ndarray
    """Every clamp post (k×2×3 mm): they stand from the start, placed profile or not."""


class RobotCell:
    """iiwa arms (none, one or two) with parallel grippers over a fixture table, in MuJoCo."""

    def __init__(self, **cell_cfg: Any) -> None:
        self.config = typed(CellConfig, cell_cfg, "cell")
        check_cell(self.config)
        cfg = self.config
        self.model = mujoco.MjModel.from_xml_string(mjcf.build_cell_xml(cfg))
        self.data = mujoco.MjData(self.model)
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
        geom = self.model.geom
        self._slots = np.array([geom(f"slot{i}").id for i in range(mjcf.part_slot_count(cfg))])
        self._tool = np.array([geom(f"tool_{name}").id for name in mjcf.TOOL_BOXES])
        self._tool_qpos = np.array([self.model.joint(f"tool_{a}").qposadr[0] for a in "xyz"])
        self._qpos = [
            np.array([self.model.joint(f"arm{a}_a{k}").qposadr[0] for k in range(1, 8)])
            for a in range(len(self.arms))
        ]
        self._slot_of = np.full(self.model.ngeom, -1)
        self._slot_of[self._slots] = np.arange(len(self._slots))
        self._link_of = np.full(self.model.ngeom, -1)
        self._arm_of = np.full(self.model.ngeom, -1)
        for a in range(len(self.arms)):
            for k, link in enumerate(mjcf.LINKS):
                self._link_of[geom(f"arm{a}_{link}").id] = k
                self._arm_of[geom(f"arm{a}_{link}").id] = a
        self._tool_body = np.full(self.model.ngeom, -1)
        self._tool_body[self._tool] = [_FINGER, _FINGER, _PALM, _HELD, _HELD]
        self._table = geom("table").id
        self._slot_owner = np.full(len(self._slots), -1)
        self._slot_kind = np.zeros(len(self._slots), dtype=int)
        self._tolerance = cfg.touch_tolerance
        self._radii = np.asarray(cfg.arm.link_radii, dtype=float)
        self._parked = np.array([mjcf.park_position(0, k) for k in range(len(self._slots))])
        self._tool_parked = np.array([mjcf.park_position(1, k) for k in range(len(self._tool))])
        self._place(self._slots, np.zeros((0, 2, 3)), self._parked)
        self._place(self._tool, np.zeros((0, 2, 3)), self._tool_parked)

    @property
    def n_arms(self) -> int:
        return len(self.arms)

    def grasps(self, assembly: Assembly, part: int) -> list[Grasp]:
        """The grasp candidates of a part, in the order `PlacementOption.grasp` indexes."""
        return grasp_candidates(
            assembly.parts[part], self.config.gripper, self.config.grasp_fractions
        )

    # Scenes ---------------------------------------------------------------------------------

    def scene(self, assembly: Assembly) -> Scene:
        """The assembly's obstacles (parts and clamps), loaded into the MuJoCo slots."""
        if assembly.n_parts > self.config.max_parts:
            raise UserError(
                f"{CONFIG_DIR}/cell: field 'max_parts' = {self.config.max_parts} is too small for "
                f"assembly '{assembly.name}' of {assembly.n_parts} parts; raise it"
            )
        room = self.config.gripper.finger_thickness
        clamps = clamp_boxes(assembly, self.config.clamp, room, self._tolerance)
        boxes, owner, kind, fixed = [], [], [], []
        for i, part in enumerate(assembly.parts):
            for k, group in enumerate((part_boxes(part), clamps[i])):
                boxes.extend(group)
                owner.extend([i] * len(group))
                kind.extend([k] * len(group))
                fixed.extend([k == 1 and b == 0 for b in range(len(group))])
        arr = np.array(boxes).reshape(-1, 2, 3)
        scene = Scene(
            assembly,
            clamps,
            arr[:, 0],
            arr[:, 1],
            np.array(owner),
            np.array(kind),
            np.array(fixed, dtype=bool),
        )
        self._load(scene, scene.present(list(range(assembly.n_parts))))
        return scene

    def _load(self, scene: Scene, keep: np.ndarray) -> None:
        """Put the boxes `keep` selects into the slots (the rest parked)."""
        boxes = np.stack([scene.lo[keep], scene.hi[keep]], axis=1)
        self._place(self._slots, boxes, self._parked)
        self._slot_owner[:] = -1
        self._slot_owner[: keep.sum()] = scene.owner[keep]
        self._slot_kind[: keep.sum()] = scene.column[keep]

    def _place(self, geoms: np.ndarray, boxes: np.ndarray, parked: np.ndarray) -> None:
        """Move the first len(boxes) geoms of a pool onto `boxes` (mm) and park the rest."""
        n = len(boxes)
        used = geoms[:n]
        half = (boxes[:, 1] - boxes[:, 0]) / 2 * mjcf.MM
        self.model.geom_pos[used] = (boxes[:, 0] + boxes[:, 1]) / 2 * mjcf.MM
        self.model.geom_size[used] = half
        self.model.geom_rbound[used] = np.linalg.norm(half, axis=1)
        self.model.geom_aabb[used, :3] = 0.0
        self.model.geom_aabb[used, 3:] = half
        rest = geoms[n:]
        self.model.geom_pos[rest] = parked[n:]
        self.model.geom_size[rest] = _PARKED_HALF
        self.model.geom_rbound[rest] = np.sqrt(3) * _PARKED_HALF
        self.model.geom_aabb[rest, :3] = 0.0
        self.model.geom_aabb[rest, 3:] = _PARKED_HALF

    # Cached options --------------------------------------------------------------------------

    def placement_options(
        self, assembly: Assembly, part: int, motions: list[Motion]
    ) -> list[PlacementOption]:
        """The options of one part (a scene of its own)."""
        return self.part_options(self.scene(assembly), part, motions)

    def part_options(self, scene: Scene, part: int, motions: list[Motion]) -> list[PlacementOption]:
        assembly = scene.assembly
        grasps = self.grasps(assembly, part)
        # Motions along the same path (they differ in the joints they make) are swept once.
        paths: dict[bytes, int] = {}
        path_of = [paths.setdefault(m.waypoints.tobytes(), i) for i, m in enumerate(motions)]
        swept = sorted(set(path_of))
        combos = [(g, m) for g in range(len(grasps)) for m in swept]
        row = {combo: c for c, combo in enumerate(combos)}
        tool = self._tool_masks(scene, part, grasps, motions, combos)
        own = np.int64(1) << part
        step = self.config.arm_sample_step
        offsets = {m: tcp_samples((0.0, 0.0, 0.0), motions[m], step) for m in swept}
        samples = [grasps[g].tcp + offsets[m] for g, m in combos]
        arm_results = [
            self._arm_masks(scene, part, grasps, samples, combos, a) for a in range(self.n_arms)
        ]
        out = []
        for g, m in ((g, m) for g in range(len(grasps)) for m in range(len(motions))):
            c = row[(g, path_of[m])]
            base = tool[c].copy()
            base[category("joint", "part")] = motions[m].joint_blockers & ~own
            if not self.arms:
                out.append(PlacementOption(-1, -1, g, m, True, True, tuple(int(x) for x in base)))
                continue
            for a, results in enumerate(arm_results):
                if not results[c]:
                    out.append(
                        PlacementOption(a, -1, g, m, False, True, tuple(int(x) for x in base))
                    )
                for branch, clear, arm in results[c]:
                    masks = tuple(int(x) for x in base | arm)
                    out.append(PlacementOption(a, branch, g, m, True, clear, masks))
        return out

    def _tool_masks(
        self,
        scene: Scene,
        part: int,
        grasps: list[Grasp],
        motions: list[Motion],
        combos: list[tuple[int, int]],
    ) -> np.ndarray:
        """Per combo (grasp, motion), the category masks of fingers, palm and held part."""
        held = part_boxes(scene.assembly.parts[part])
        boxes, labels = [], []
        for c, (g, m) in enumerate(combos):
            solid = np.concatenate([grasps[g].gripper_boxes(self.config.gripper), held])
            body = np.array([_FINGER, _FINGER, _PALM] + [_HELD] * len(held))
            swept = swept_boxes(solid, motions[m])
            boxes.append(swept)
            labels.append(c * len(BODIES) + np.tile(body, len(swept) // len(solid)))
        rows = np.concatenate(boxes)
        keys = np.concatenate(labels)
        other = scene.obstacles_for(part)
        lo, hi = scene.lo[other], scene.hi[other]
        depth = np.minimum(rows[:, None, 1], hi[None]) - np.maximum(rows[:, None, 0], lo[None])
        hits = (depth > self._tolerance).all(axis=-1)
        out = np.zeros((len(combos) * len(BODIES), len(KINDS)), dtype=np.int64)
        for k in range(len(KINDS)):
            bits = np.where(hits & (scene.column[other] == k), scene.bits[other], 0)
            np.bitwise_or.at(out[:, k], keys, np.bitwise_or.reduce(bits, axis=1))
        return out.reshape(len(combos), N_CATEGORIES)

    def _arm_masks(
        self,
        scene: Scene,
        part: int,
        grasps: list[Grasp],
        samples: list[np.ndarray],
        combos: list[tuple[int, int]],
        arm: int,
    ) -> list[list[tuple[int, bool, np.ndarray]]]:
        """Per combo, (branch, clear of table and self, category masks) of the arm's usable IK
        branches (at most `max_branches`, preferred first); [] if none reaches. `samples` holds
        per combo the TCP positions (mm) along its motion."""
        kin = self.arms[arm]
        bounds = np.cumsum([0, *(len(s) for s in samples)])
        tcp = np.concatenate(samples) * mjcf.MM
        yaw = np.concatenate(
            [np.full(len(s), grasps[g].yaw) for s, (g, _) in zip(samples, combos, strict=True)]
        )
        q, ok = kin.top_down_ik(tcp, yaw)
        pairs = [
            (c, int(b))
            for c in range(len(combos))
            for b in np.flatnonzero(ok[:, bounds[c] : bounds[c + 1]].all(axis=1))[
                : self.config.max_branches
            ]
        ]
        out: list[list[tuple[int, bool, np.ndarray]]] = [[] for _ in combos]
        if not pairs:
            return out
        rows = np.concatenate([np.arange(bounds[c], bounds[c + 1]) for c, _ in pairs])
        branch = np.concatenate([np.full(bounds[c + 1] - bounds[c], b) for c, b in pairs])
        pair_of = np.repeat(np.arange(len(pairs)), [bounds[c + 1] - bounds[c] for c, _ in pairs])
        poses = q[branch, rows]
        near = self._near(scene, part, kin.link_points(poses) / mjcf.MM)
        clear = np.ones(len(pairs), dtype=bool)
        masks = np.zeros((len(pairs), N_CATEGORIES), dtype=np.int64)
        adr = self._qpos[arm]
        for k in np.flatnonzero(near):
            self.data.qpos[adr] = poses[k]
            for link, owner, kind in self._contacts(arm):
                if owner == -1:
                    clear[pair_of[k]] = False
                elif owner != part or KINDS[kind] == "post":
                    masks[pair_of[k], category(f"arm_{mjcf.LINKS[link]}", KINDS[kind])] |= (
                        np.int64(1) << owner
                    )
        self.data.qpos[adr] = 0.0
        for i, (c, b) in enumerate(pairs):
            out[c].append((b, bool(clear[i]), masks[i]))
        return out

    def _near(self, scene: Scene, part: int, points: np.ndarray) -> np.ndarray:
        """Samples (K) whose link capsules' bounds (points: K×5×3 mm) meet another part's or
        clamp's box, the table top, or each other (non-adjacent links): MuJoCo decides those."""
        radii = self._radii[None, :, None]
        lo = np.minimum(points[:, :-1], points[:, 1:]) - radii
        hi = np.maximum(points[:, :-1], points[:, 1:]) + radii
        other = scene.obstacles_for(part)
        olo, ohi = scene.lo[other], scene.hi[other]
        # Only links reaching down to the obstacles' top can meet them (most stay far above).
        sample, link = np.nonzero(lo[:, :, 2] < ohi[:, 2].max(initial=0.0) - self._tolerance)
        depth = np.minimum(hi[sample, link, None], ohi[None]) - np.maximum(
            lo[sample, link, None], olo[None]
        )
        near = np.zeros(len(points), dtype=bool)
        near[sample[(depth > self._tolerance).all(axis=-1).any(axis=1)]] = True
        near |= (lo[:, :, 2] < -self._tolerance).any(axis=1)
        for a, b in ((0, 2), (0, 3), (1, 3)):
            near |= ((np.minimum(hi[:, a], hi[:, b]) - np.maximum(lo[:, a], lo[:, b])) > 0).all(
                axis=-1
            )
        return near

    def _contacts(self, arm: int) -> list[tuple[int, int, int]]:
        """(link, owner part, obstacle kind index in `KINDS`) of the arm's penetrating contacts
        in the current pose; owner −1 for the table or the arm itself."""
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_collision(self.model, self.data)
        ncon = self.data.ncon
        out = []
        if not ncon:
            return out
        contact = self.data.contact
        deep = contact.dist[:ncon] < -self._tolerance * mjcf.MM
        for g1, g2 in contact.geom[:ncon][deep]:
            link_geom, other = (g1, g2) if self._arm_of[g1] == arm else (g2, g1)
            if self._arm_of[link_geom] != arm:
                continue
            link = int(self._link_of[link_geom])
            slot = self._slot_of[other]
            if slot >= 0:
                out.append((link, int(self._slot_owner[slot]), int(self._slot_kind[slot])))
            elif other == self._table or self._arm_of[other] == arm:
                out.append((link, -1, 0))
        return out

    # Reference check -------------------------------------------------------------------------

    def check_placement(
        self,
        assembly: Assembly,
        part: int,
        placed: int,
        motion: Motion,
        rules: Mapping[str, bool] | None = None,
    ) -> bool:
        """Uncached reference: only the parts of `placed` (and, with the clamps rule, their
        clamps' arms and every clamp post) in MuJoCo; True if some arm, IK branch and grasp
        place `part` along `motion` with nothing penetrating, the tool sampled every
        `REFERENCE_STEP_MM` and the arm at the cached samples. Rules switched off in `rules` are
        not checked."""
        on = {r: True for r in RULES} | dict(rules or {})
        if on["joints"] and motion.joint_blockers & placed & ~(1 << part):
            return False
        scene = self.scene(assembly)
        before = [i for i in mask_to_parts(placed) if i != part]
        self._load(scene, scene.present(before, clamps=on["clamps"]))
        held = part_boxes(assembly.parts[part])
        enabled = np.array(
            [on["fingers"], on["fingers"], on["palm"], on["held_part"], on["held_part"]]
        )
        try:
            for grasp in self.grasps(assembly, part):
                solid = np.concatenate([grasp.gripper_boxes(self.config.gripper), held])
                self._place(self._tool, solid, self._tool_parked)
                self.model.geom_contype[self._tool] = np.where(enabled, mjcf.TOOL_BIT, 0)
                if self._tool_clear(motion) and self._some_arm(grasp, motion, on):
                    return True
            return False
        finally:
            self.model.geom_contype[self._tool] = mjcf.TOOL_BIT
            self._place(self._tool, np.zeros((0, 2, 3)), self._tool_parked)
            self.data.qpos[:] = 0.0
            self._load(scene, scene.present(list(range(assembly.n_parts))))

    def _tool_clear(self, motion: Motion) -> bool:
        for offset in tcp_samples((0.0, 0.0, 0.0), motion, REFERENCE_STEP_MM):
            self.data.qpos[self._tool_qpos] = offset * mjcf.MM
            mujoco.mj_kinematics(self.model, self.data)
            mujoco.mj_collision(self.model, self.data)
            ncon = self.data.ncon
            contact = self.data.contact
            for g1, g2 in contact.geom[:ncon][contact.dist[:ncon] < -self._tolerance * mjcf.MM]:
                if self._tool_body[g1] >= 0 or self._tool_body[g2] >= 0:
                    return False
        self.data.qpos[self._tool_qpos] = 0.0
        return True

    def _some_arm(self, grasp: Grasp, motion: Motion, on: Mapping[str, bool]) -> bool:
        if not self.arms:
            return True
        park = np.array([mjcf.PARK, mjcf.PARK, mjcf.PARK])
        self.data.qpos[self._tool_qpos] = park
        tcp = tcp_samples(grasp.tcp, motion, self.config.arm_sample_step) * mjcf.MM
        for arm, kin in enumerate(self.arms):
            q, ok = kin.top_down_ik(tcp, grasp.yaw)
            valid = np.flatnonzero(ok.all(axis=1))[: self.config.max_branches]
            if not len(valid):
                if not on["reach"]:
                    return True
                continue
            if not on["arm_links"]:
                return True
            for branch in valid:
                clear = True
                for sample in q[branch]:
                    self.data.qpos[self._qpos[arm]] = sample
                    if self._contacts(arm):
                        clear = False
                        break
                self.data.qpos[self._qpos[arm]] = 0.0
                if clear:
                    return True
        return False

    # Drawing --------------------------------------------------------------------------------

    def pose(self, assembly: Assembly, placed: int, part: int, option: PlacementOption) -> CellPose:
        """The cell after `part` is placed with `option` in state `placed` (for drawing)."""
        scene = self.scene(assembly)
        grasp = self.grasps(assembly, part)[option.grasp]
        angles = {a: np.zeros(7) for a in range(self.n_arms)}
        if option.arm >= 0 and option.branch >= 0:
            q, _ = self.arms[option.arm].top_down_ik(
                np.asarray(grasp.tcp)[None] * mjcf.MM, grasp.yaw
            )
            angles[option.arm] = q[option.branch, 0].copy()
        self.data.qpos[:] = 0.0
        for a, q in angles.items():
            self.data.qpos[self._qpos[a]] = q
        mujoco.mj_kinematics(self.model, self.data)
        bodies = {
            self.model.body(b).name: (
                self.data.xpos[b] / mjcf.MM,
                self.data.xmat[b].reshape(3, 3).copy(),
            )
            for b in range(1, self.model.nbody)
            if self.model.body(b).name.startswith("arm")
        }
        self.data.qpos[:] = 0.0
        tool = np.concatenate(
            [grasp.gripper_boxes(self.config.gripper), part_boxes(assembly.parts[part])]
        )
        now = placed | 1 << part
        parts = {i: scene.boxes_of([i]) for i in mask_to_parts(now)}
        return CellPose(angles, bodies, tool, parts, scene.posts())
