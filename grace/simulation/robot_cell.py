"""The robot cell: what stands in the way of one placement (docs/world.md, "The cell").

A placement option is (arm, IK branch, grasp, motion). It is `reachable` if the closed-form IK
(`kinematics.IiwaArm`) holds the grasp at every TCP sample along the motion within the joint
limits, `arm_clear` if the arm's links then stay clear of the table and of each other. Its
blocker masks say which other parts stop it, one mask per (robot body, obstacle kind):

- bodies: the motion's T-slot joints (`joint`), the two fingers, the palm (gripper body), the
  held part, and the four arm links (column, upper arm, forearm, wrist);
- obstacle kinds (`KINDS`): the part itself; its clamp's solids that stand once it is placed
  (`clamp`: an arm, a handle pushed upright); its clamp's base (`post`), on the plate from the
  start, so a hit makes an option unusable in every state, also for its own profile; and what
  its open clamp holds out until it is placed (`open`), so a hit makes an option usable only
  once that part is placed, never for its own profile (`clamps.clamp_boxes`).

A part is carried in at the height a motion starts from and lowered there: whatever stands
taller then (a closed toggle clamp's handle) would be in the way of the held part and the
fingers on the way in, wherever it stands (`Scene.carried_over`), so it joins their masks.

The fingers, palm and held part are world-aligned boxes moving along world axes, so the volume
each sweeps along a motion segment is exactly the box spanning its start and end copies; their
contacts are box overlaps. The arm links are capsules in arbitrary poses: a box test on their
bounds picks the samples where they may touch something, and MuJoCo's collision detection
decides those. `options` puts every part of the assembly and every clamp solid, whenever it
stands (bases, closed and open solids alike), into the scene at once and attributes each contact
to its owner and kind, so one query per option gives the blockers for every state: the
option is free in state S iff it hits no post, `blockers & S == 0` for the part and clamp
masks, and `needs & ~S == 0` for the open ones.
Motions share segments (the same path making other joints; the lower stretch of a descent
from a greater carry height), so tool sweeps and arm samples are worked out once per segment.
`check_placement` is the uncached reference: only the parts and clamp solids standing in one
state in MuJoCo, tool and arm sampled every few millimetres.
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
from grace.simulation.cell_config import (
    CLAMP_STATES,
    CONFIG_DIR,
    RULES,
    CellConfig,
    check_cell,
    typed,
)
from grace.simulation.clamps import Clamp, clamp_boxes
from grace.simulation.clearance import (
    Grasp,
    grasp_candidates,
    part_boxes,
    segment_samples,
    segment_sweeps,
    tcp_samples,
)
from grace.simulation.kinematics import IiwaArm

BODIES = ("joint", "finger", "palm", "held_part", *(f"arm_{link}" for link in mjcf.LINKS))
KINDS = ("part", "clamp", "post", "open")
"""Obstacle kinds: a part and its clamp's solids standing once it is placed, at every step, or
until it is placed (docs/world.md, "The cell")."""
_KIND_OF_STATE = {"always": "post", "open": "open", "closed": "clamp"}
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
_PART, _CLAMP, _POST, _OPEN = (KINDS.index(k) for k in KINDS)


def category(body: str, kind: str) -> int:
    """Column of (body, obstacle kind) in `PlacementOption.masks`."""
    return BODIES.index(body) * len(KINDS) + KINDS.index(kind)


@dataclass(frozen=True)
class PlacementOption:
    """One way to place a part; `arm` = −1 in a cell without robot, `branch` = −1 if no IK
    branch reaches. `masks[category(body, kind)]` is the bitmask of parts whose body or clamp
    solid of that kind the robot body would penetrate (for an unreachable option only the tool
    and the joint); a post is there in every state, an open clamp's solid until its part is
    placed, the rest once its part is placed."""

    arm: int
    branch: int
    grasp: int
    motion: int
    reachable: bool
    arm_clear: bool
    masks: tuple[int, ...]

    @property
    def posts(self) -> int:
        """Bitmask of the profiles whose clamp base any robot body would hit."""
        out = 0
        for body in BODIES:
            out |= self.masks[category(body, "post")]
        return out

    @property
    def blockers(self) -> int:
        """Bitmask of the parts whose body or closed clamp would stop this option once placed."""
        out = 0
        for c, m in enumerate(self.masks):
            if KINDS[c % len(KINDS)] in ("part", "clamp"):
                out |= m
        return out

    @property
    def needs(self) -> int:
        """Bitmask of the parts whose open clamp stands in the way until they are placed."""
        out = 0
        for body in BODIES:
            out |= self.masks[category(body, "open")]
        return out

    def free(self, placed: int) -> bool:
        """Usable with every rule on once the parts of bitmask `placed` are placed."""
        return (
            self.reachable
            and self.arm_clear
            and not self.posts
            and not self.blockers & placed
            and not self.needs & ~placed
        )


@dataclass
class Scene:
    """One assembly's obstacles: every part's boxes and its clamp's solids, with owner and
    `column`, the obstacle kind's index in `KINDS`; `kind` is 0 for a part's box, 1 for a clamp
    solid standing once its part is placed or always, 2 for one standing until then."""

    assembly: Assembly
    clamps: list[Clamp]
    lo: np.ndarray
    hi: np.ndarray
    owner: np.ndarray
    column: np.ndarray
    bits: np.ndarray = field(init=False)
    kind: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.bits = np.left_shift(np.int64(1), self.owner.astype(np.int64))
        self.kind = np.select([self.column == _PART, self.column == _OPEN], [0, 2], 1)

    def carry_heights(self, clearance: float) -> list[float]:
        """Heights (mm) a part may be carried in at: `clearance` above the tallest part or clamp
        base (they may stand at any step), and above the top of every taller clamp solid
        (docs/world.md, "Motions")."""
        floor = float(self.hi[(self.column == _PART) | (self.column == _POST), 2].max(initial=0))
        tops = np.unique(np.round(self.hi[:, 2], 6))
        return [float(t) + clearance for t in (floor, *tops[tops > floor])]

    def carried_over(self, part: int, height: float, tolerance: float) -> np.ndarray:
        """Boxes that can stop `part` and stand taller than `height` (mm): a part carried in at
        that height would sweep through them when they stand."""
        return self.obstacles_for(part) & (self.hi[:, 2] > height + tolerance)

    def present(self, parts: list[int], clamps: bool = True) -> np.ndarray:
        """Which boxes stand in the cell once `parts` are placed: theirs, and with clamps their
        closed clamps, every clamp's base and the open clamps of the other parts."""
        placed = np.isin(self.owner, parts)
        column = self.column
        standing = (placed & (column == _CLAMP)) | (column == _POST) | (~placed & (column == _OPEN))
        return (placed & (column == _PART)) | (clamps & standing)

    def everything(self) -> np.ndarray:
        """Every box, whenever it stands (parts, clamp bases, closed and open clamp solids): the
        cached queries put them all in the scene at once and attribute each contact to its
        owner and kind, so no state's obstacles are missing for any robot body."""
        return np.ones(len(self.owner), dtype=bool)

    def boxes_of(self, parts: list[int], clamps: bool = True) -> np.ndarray:
        """World boxes (k×2×3, mm) of `parts` and, if asked, their clamps as they stand once
        the parts are placed (closed)."""
        keep = np.isin(self.owner, parts) & ((self.kind == 0) | (clamps & (self.kind == 1)))
        return np.stack([self.lo[keep], self.hi[keep]], axis=1)

    def posts(self) -> np.ndarray:
        """Every clamp's base (k×2×3, mm): on the plate before any part arrives."""
        keep = self.column == _POST
        return np.stack([self.lo[keep], self.hi[keep]], axis=1)

    def obstacles_for(self, part: int) -> np.ndarray:
        """Boxes that can stop `part`: all but its own body and what its clamp brings on closing
        (its base and its open clamp stand while it is placed)."""
        return (self.owner != part) | (self.column == _POST) | (self.column == _OPEN)


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
    """Every clamp's base (k×2×3 mm): they stand from the start, placed profile or not."""


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
        self._track = [
            self.model.joint(f"arm{a}_track").qposadr[0] if cfg.track else None
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
        self._loaded: Scene | None = None  # the scene whose every box the slots hold
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

    def carriage(self, arm: int, grasp: Grasp) -> float:
        """Where (mm along world y from its base) the arm's carriage stops for `grasp`: opposite
        the grasp within the track's travel; 0 on a fixed pedestal."""
        if not self.config.track:
            return 0.0
        lo, hi = self.config.track
        return float(np.clip(grasp.tcp[1] - self.config.bases[arm][1], lo, hi))

    def _move_carriage(self, arm: int, offset: float) -> None:
        if self._track[arm] is not None:
            self.data.qpos[self._track[arm]] = offset * mjcf.MM

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
        boxes, owner, column = [], [], []
        for i, part in enumerate(assembly.parts):
            own = part_boxes(part)
            boxes += [*own, *clamps[i].boxes]
            owner += [i] * (len(own) + len(clamps[i].boxes))
            column += [_PART] * len(own)
            column += [KINDS.index(_KIND_OF_STATE[CLAMP_STATES[w]]) for w in clamps[i].when]
        arr = np.array(boxes).reshape(-1, 2, 3)
        scene = Scene(assembly, clamps, arr[:, 0], arr[:, 1], np.array(owner), np.array(column))
        self._load(scene, scene.everything())
        return scene

    def _load(self, scene: Scene, keep: np.ndarray) -> None:
        """Put the boxes `keep` selects into the slots (the rest parked)."""
        boxes = np.stack([scene.lo[keep], scene.hi[keep]], axis=1)
        self._place(self._slots, boxes, self._parked)
        self._loaded = scene if keep.all() else None
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
        """The options of one part of a scene `scene()` built (loaded again if another one
        was loaded since: the MuJoCo slots hold one scene at a time)."""
        if self._loaded is not scene:
            self._load(scene, scene.everything())
        assembly = scene.assembly
        grasps = self.grasps(assembly, part)
        # Motions share segments (the same path making other joints, the lower stretch of a
        # descent from a greater height): each segment is swept and sampled once per grasp.
        index: dict[bytes, int] = {}
        segments: list[tuple[np.ndarray, np.ndarray]] = []
        uses = []
        for motion in motions:
            ids = []
            for a, b in motion.segments():
                ids.append(index.setdefault(a.tobytes() + b.tobytes(), len(segments)))
                if ids[-1] == len(segments):
                    segments.append((a, b))
            uses.append(ids)
        through = np.zeros((len(motions), len(segments)), dtype=bool)
        for m, ids in enumerate(uses):
            through[m, ids] = True
        tool = self._tool_masks(scene, part, grasps, segments)
        tool = np.stack([np.bitwise_or.reduce(tool[:, ids], axis=1) for ids in uses], axis=1)
        heights = [float(motion.waypoints[0][2]) for motion in motions]
        carried = {h: self._carried_masks(scene, part, h) for h in set(heights)}
        tool |= np.array([carried[h] for h in heights])[None]
        step = self.config.arm_sample_step
        offsets = [segment_samples(a, b, step) for a, b in segments]
        tool[:, :, category("joint", "part")] = [m.joint_blockers & ~(1 << part) for m in motions]
        arms = [
            self._arm_masks(scene, part, grasps, offsets, through, a) for a in range(self.n_arms)
        ]
        rows = tool.tolist()
        per_arm = [(b.tolist(), c.tolist(), (tool[:, :, None] | k).tolist()) for b, c, k in arms]
        out = []
        for g, m in ((g, m) for g in range(len(grasps)) for m in range(len(motions))):
            if not self.arms:
                out.append(PlacementOption(-1, -1, g, m, True, True, tuple(rows[g][m])))
                continue
            for a, (branches, clear, masks) in enumerate(per_arm):
                if branches[g][m][0] < 0:
                    out.append(PlacementOption(a, -1, g, m, False, True, tuple(rows[g][m])))
                for k, branch in enumerate(branches[g][m]):
                    if branch >= 0:
                        both = tuple(masks[g][m][k])
                        out.append(PlacementOption(a, branch, g, m, True, clear[g][m][k], both))
        return out

    def _carried_masks(self, scene: Scene, part: int, height: float) -> np.ndarray:
        """Category masks of what stands taller than the `height` the part is carried in at (a
        motion's start): the held part and the fingers beside it would sweep through it."""
        out = np.zeros(N_CATEGORIES, dtype=np.int64)
        over = scene.carried_over(part, height, self._tolerance)
        for k in range(len(KINDS)):
            bits = np.bitwise_or.reduce(scene.bits[over & (scene.column == k)], initial=0)
            for body in ("finger", "held_part"):
                out[category(body, KINDS[k])] |= bits
        return out

    def _tool_masks(
        self,
        scene: Scene,
        part: int,
        grasps: list[Grasp],
        segments: list[tuple[np.ndarray, np.ndarray]],
    ) -> np.ndarray:
        """Per grasp and segment (G×S×categories), the masks of fingers, palm and held part."""
        held = part_boxes(scene.assembly.parts[part])
        body = np.array([_FINGER, _FINGER, _PALM] + [_HELD] * len(held))
        starts = np.array([a for a, _ in segments])[:, None]
        ends = np.array([b for _, b in segments])[:, None]
        boxes, labels = [], []
        for g, grasp in enumerate(grasps):
            solid = np.concatenate([grasp.gripper_boxes(self.config.gripper), held])
            boxes.append(segment_sweeps(solid, starts, ends).reshape(-1, 2, 3))
            rows = (g * len(segments) + np.arange(len(segments)))[:, None] * len(BODIES)
            labels.append((rows + body[None]).ravel())
        rows = np.concatenate(boxes)
        keys = np.concatenate(labels)
        other = scene.obstacles_for(part)
        lo, hi = scene.lo[other], scene.hi[other]
        depth = np.minimum(rows[:, None, 1], hi[None]) - np.maximum(rows[:, None, 0], lo[None])
        hits = (depth > self._tolerance).all(axis=-1)
        out = np.zeros((len(grasps) * len(segments) * len(BODIES), len(KINDS)), dtype=np.int64)
        for k in range(len(KINDS)):
            bits = np.where(hits & (scene.column[other] == k), scene.bits[other], 0)
            np.bitwise_or.at(out[:, k], keys, np.bitwise_or.reduce(bits, axis=1))
        return out.reshape(len(grasps), len(segments), N_CATEGORIES)

    def _arm_masks(
        self,
        scene: Scene,
        part: int,
        grasps: list[Grasp],
        offsets: list[np.ndarray],
        through: np.ndarray,
        arm: int,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The arm's usable IK branches per grasp and motion (at most `max_branches`, preferred
        first): `branches` (G×M×B, −1 where none), whether each stays clear of table and self,
        and its category masks (G×M×B×categories). A motion's arm is sampled segment by segment
        (`offsets[s]`: TCP offsets along segment s; `through[m, s]`: motion m passes it); every
        motion through a segment shares its samples, and a branch must hold the IK at every
        sample of the motion."""
        kin = self.arms[arm]
        n_grasps, n_segments = len(grasps), len(offsets)
        per = np.tile([len(o) for o in offsets], n_grasps)
        starts = np.cumsum([0, *per])[:-1]
        tcp = np.concatenate([np.asarray(g.tcp) + o for g in grasps for o in offsets]) * mjcf.MM
        yaw = np.repeat([g.yaw for g in grasps], per.sum() // n_grasps)
        # The carriage's offset per sample (mm along y): the IK sees the TCP from the moved base.
        carried = np.repeat([self.carriage(arm, g) for g in grasps], per.sum() // n_grasps)
        tcp[:, 1] -= carried * mjcf.MM
        q, ok = kin.top_down_ik(tcp, yaw)
        # Per branch, grasp and segment: the IK holds at every sample; then per motion.
        holds = np.logical_and.reduceat(ok, starts, axis=1).reshape(len(ok), n_grasps, -1)
        fails = (~holds).astype(np.int32) @ through.T.astype(np.int32)  # B×G×M
        valid = fails == 0
        keep = valid & (np.cumsum(valid, axis=0) <= self.config.max_branches)
        needed = (keep.astype(np.int32) @ through.astype(np.int32)) > 0  # B×G×S
        clear = np.ones(needed.shape, dtype=bool)
        masks = np.zeros((*needed.shape, N_CATEGORIES), dtype=np.int64)
        b_idx, g_idx, s_idx = np.nonzero(needed)
        if len(b_idx):
            cells = starts[g_idx * n_segments + s_idx]
            sizes = per[g_idx * n_segments + s_idx]
            first = np.cumsum(sizes) - sizes
            rows = np.arange(sizes.sum()) + np.repeat(cells - first, sizes)
            owner_of = np.repeat(np.arange(len(b_idx)), sizes)
            poses = q[np.repeat(b_idx, sizes), rows]
            points = kin.link_points(poses) / mjcf.MM
            points[..., 1] += carried[rows, None]
            near = self._near(scene, part, points)
            adr = self._qpos[arm]
            for k in np.flatnonzero(near):
                self.data.qpos[adr] = poses[k]
                self._move_carriage(arm, carried[rows[k]])
                cell = (b_idx[owner_of[k]], g_idx[owner_of[k]], s_idx[owner_of[k]])
                for link, owner, kind in self._contacts(arm):
                    if owner == -1:
                        clear[cell] = False
                    elif owner != part or kind in (_POST, _OPEN):
                        masks[(*cell, category(f"arm_{mjcf.LINKS[link]}", KINDS[kind]))] |= (
                            np.int64(1) << owner
                        )
            self.data.qpos[adr] = 0.0
            self._move_carriage(arm, 0.0)
        branches = np.full((n_grasps, len(through), self.config.max_branches), -1)
        rank = np.cumsum(keep, axis=0) - 1
        b_of, g_of, m_of = np.nonzero(keep)
        branches[g_of, m_of, rank[b_of, g_of, m_of]] = b_of
        # Per grasp, motion and chosen branch: clear at every segment it passes, the masks of
        # all of them (only segments where the arm met something change anything).
        pick = np.where(branches >= 0, branches, 0)
        g_at = np.arange(n_grasps)[:, None, None]
        chosen_clear = np.ones(branches.shape, dtype=bool)
        chosen_masks = np.zeros((*branches.shape, N_CATEGORIES), dtype=np.int64)
        for s in np.flatnonzero((masks.any(axis=-1) | ~clear).any(axis=(0, 1))):
            on = through[:, s][None, :, None]
            chosen_clear &= ~on | clear[pick, g_at, s]
            chosen_masks |= np.where(on[..., None], masks[pick, g_at, s], 0)
        return branches, chosen_clear, chosen_masks

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
        """Uncached reference: only the parts of `placed` (and, with the clamps rule, the clamp
        solids standing then: `Scene.present`) in MuJoCo; True if some arm, IK branch and grasp
        place `part` along `motion` with nothing penetrating, the tool sampled every
        `REFERENCE_STEP_MM` and the arm at the cached samples. Rules switched off in `rules` are
        not checked."""
        on = {r: True for r in RULES} | dict(rules or {})
        if on["joints"] and motion.joint_blockers & placed & ~(1 << part):
            return False
        scene = self.scene(assembly)
        before = [i for i in mask_to_parts(placed) if i != part]
        present = scene.present(before, clamps=on["clamps"])
        height = float(motion.waypoints[0][2])
        if (on["fingers"] or on["held_part"]) and (
            present & scene.carried_over(part, height, self._tolerance)
        ).any():
            return False  # carried in at that height, it would sweep through something taller
        self._load(scene, present)
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
            self._load(scene, scene.everything())

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
            offset = self.carriage(arm, grasp)
            q, ok = kin.top_down_ik(tcp - np.array([0.0, offset * mjcf.MM, 0.0]), grasp.yaw)
            valid = np.flatnonzero(ok.all(axis=1))[: self.config.max_branches]
            if not len(valid):
                if not on["reach"]:
                    return True
                continue
            if not on["arm_links"]:
                return True
            self._move_carriage(arm, offset)  # check_placement resets every qpos
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
        offset = 0.0
        if option.arm >= 0 and option.branch >= 0:
            offset = self.carriage(option.arm, grasp)
            tcp = (np.asarray(grasp.tcp) - np.array([0.0, offset, 0.0]))[None] * mjcf.MM
            q, _ = self.arms[option.arm].top_down_ik(tcp, grasp.yaw)
            angles[option.arm] = q[option.branch, 0].copy()
        self.data.qpos[:] = 0.0
        for a, q in angles.items():
            self.data.qpos[self._qpos[a]] = q
        if option.arm >= 0:
            self._move_carriage(option.arm, offset)
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
