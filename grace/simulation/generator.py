"""Random fixture-frame structures of aluminium profiles and angle brackets (issue 2, the world).

A structure grows from one profile by joints that real frames use: T-joints (a profile's end
against another's long side anywhere along it), L-corners (a profile capping another's end),
end-to-end extensions, parallel rails (several T-stems off one bar at sampled gaps, some narrower
than a gripper finger) and angle brackets in the inner corners of T and L joints. Every number
comes from the `generator:` block of `grace/conf/simulator/dual_arm.yaml`. Parts are axis-aligned
(`planar_pose`), never overlap, each touches the structure; the result is centred on the world
origin and named part_1..part_N in `canonical_order` (SPEC §2).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from grace.domain.assembly import (
    BRACKET_LEG_MM,
    PROFILE_SECTION_MM,
    Assembly,
    Part,
    PartType,
    canonical_order,
    planar_pose,
)
from grace.simulation.joints import end_joints, parts_contact, parts_overlap

CONFIG_FILE = "grace/conf/simulator/dual_arm.yaml"
HALF = PROFILE_SECTION_MM / 2
FIELDS = {
    "profile_300_share",
    "joint_weights",
    "flush_corner_share",
    "bracket_share",
    "gap_mm",
    "narrow_gap_share",
    "narrow_same_length_share",
    "position_grid_mm",
    "work_area",
    "max_attempts",
    "max_restarts",
}
_AXES = {0: np.array([0.0, 1.0]), 1: np.array([1.0, 0.0])}
"""World direction of a profile's length for quarter_turns 0 and 1 (poses 2, 3 are equivalent)."""

# Quarter turns of a bracket whose two legs run along the given pair of world directions.
_BRACKET_TURNS = {
    frozenset({(1, 0), (0, 1)}): 0,
    frozenset({(0, 1), (-1, 0)}): 1,
    frozenset({(-1, 0), (0, -1)}): 2,
    frozenset({(0, -1), (1, 0)}): 3,
}


class StructureGenerator:
    """Grows connected profile frames; `generate(n, rng)` is deterministic in `rng`'s state.

    `finger_mm` is the width a gripper finger needs beside a part (from the cell config): rail
    gaps are drawn narrower than it with probability `narrow_gap_share`, wider otherwise.
    """

    def __init__(self, finger_mm: float, tolerance: float = 0.5, **cfg: Any) -> None:
        for name in sorted(FIELDS ^ set(cfg)):
            problem, fix = ("missing", "add it") if name in FIELDS else ("unknown", "remove it")
            raise ValueError(f"{CONFIG_FILE}: {problem} field 'generator.{name}'; {fix}")
        lo, hi = cfg["gap_mm"]
        if not lo < finger_mm < hi:
            raise ValueError(
                f"{CONFIG_FILE}: field 'generator.gap_mm' = [{lo}, {hi}] must straddle the "
                f"finger size {finger_mm} mm so rails fall on both sides of it; widen it"
            )
        self.cfg = cfg
        self.finger_mm = float(finger_mm)
        self.tolerance = tolerance
        self.actions: dict[str, Callable[[list[Part], np.random.Generator], Part | None]] = {
            "t_joint": self._t_joint,
            "cap": self._cap,
            "end_to_end": self._end_to_end,
            "rail": self._rail,
        }
        unknown = set(cfg["joint_weights"]) - set(self.actions)
        if unknown:
            raise ValueError(
                f"{CONFIG_FILE}: field 'generator.joint_weights' has unknown kinds "
                f"{sorted(unknown)}; use {sorted(self.actions)}"
            )
        weights = np.array([float(cfg["joint_weights"].get(k, 0.0)) for k in self.actions])
        self.weights = weights / weights.sum()

    def generate(self, n_parts: int, rng: np.random.Generator) -> Assembly:
        """A connected structure of `n_parts` parts, centred and canonically named."""
        if n_parts < 1:
            raise ValueError(f"generate: n_parts must be ≥ 1, got {n_parts}")
        for _ in range(int(self.cfg["max_restarts"])):
            parts = self._grow(n_parts, rng)
            if parts is not None:
                return self._finish(parts)
        raise RuntimeError(
            f"{CONFIG_FILE}: no {n_parts}-part structure fits field 'generator.work_area' after "
            f"{self.cfg['max_restarts']} restarts; enlarge work_area or max_attempts"
        )

    def _grow(self, n_parts: int, rng: np.random.Generator) -> list[Part] | None:
        parts = [self._profile(rng, 0.0, 0.0, int(rng.integers(2)))]
        attempts = 0
        while len(parts) < n_parts:
            attempts += 1
            if attempts > int(self.cfg["max_attempts"]):
                return None
            if rng.random() < float(self.cfg["bracket_share"]):
                part = self._bracket(parts, rng)
            else:
                kind = list(self.actions)[rng.choice(len(self.actions), p=self.weights)]
                part = self.actions[kind](parts, rng)
            if part is not None and self._fits(parts, part):
                parts.append(part)
        return parts

    def _finish(self, parts: list[Part]) -> Assembly:
        lo, hi = self._extent(parts)
        shift = np.round((lo + hi) / 2)
        moved = []
        for p in parts:
            pose = p.pose.copy()
            pose[:2, 3] -= shift
            moved.append(Part(p.name, p.type, pose))
        ordered = canonical_order(moved)
        return Assembly(tuple(Part(f"part_{i + 1}", p.type, p.pose) for i, p in enumerate(ordered)))

    @staticmethod
    def _extent(parts: list[Part]) -> tuple[np.ndarray, np.ndarray]:
        boxes = np.array([b for p in parts for b in p.footprint_boxes()])
        return boxes[:, :2].min(axis=0), boxes[:, 2:].max(axis=0)

    def _fits(self, parts: list[Part], new: Part) -> bool:
        if any(parts_overlap(new, p, self.tolerance) for p in parts):
            return False
        contacts = [p for p in parts if parts_contact(new, p, self.tolerance) > 0]
        if not contacts:
            return False
        # A bracket joins exactly the two profiles of its corner and touches nothing else.
        if new.type.is_profile and any(not p.type.is_profile for p in contacts):
            return False
        if not new.type.is_profile and len(contacts) != 2:
            return False
        lo, hi = self._extent([*parts, new])
        width, depth = self.cfg["work_area"]
        return bool(hi[0] - lo[0] <= width and hi[1] - lo[1] <= depth)

    def _profile(self, rng: np.random.Generator, x: float, y: float, axis: int) -> Part:
        long = rng.random() < float(self.cfg["profile_300_share"])
        kind = PartType.PROFILE_300 if long else PartType.PROFILE_200
        return Part("new", kind, planar_pose(x, y, axis))

    def _along(self, rng: np.random.Generator, half_span: float) -> float:
        """A grid position in [−half_span, half_span] (the `position_grid_mm` raster)."""
        grid = float(self.cfg["position_grid_mm"])
        steps = int(half_span // grid)
        return float(rng.integers(-steps, steps + 1)) * grid

    @staticmethod
    def _axis(part: Part) -> int:
        return part.quarter_turns % 2

    def _host(self, parts: list[Part], rng: np.random.Generator) -> Part:
        profiles = [p for p in parts if p.type.is_profile]
        return profiles[rng.integers(len(profiles))]

    def _stem(
        self,
        host: Part,
        side: int,
        along: float,
        rng: np.random.Generator,
        kind: PartType | None = None,
    ) -> Part:
        """A profile (of `kind`, random if None) on `host`'s long side `side` (±1), `along` mm
        from its centre."""
        axis = self._axis(host)
        u, n = _AXES[axis], _AXES[1 - axis]
        kind = kind or self._profile(rng, 0.0, 0.0, 1 - axis).type
        centre = np.asarray(host.xy) + u * along + n * side * (HALF + kind.length / 2)
        return Part("new", kind, planar_pose(centre[0], centre[1], 1 - axis))

    def _t_joint(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        host = self._host(parts, rng)
        along = self._along(rng, host.type.length / 2 - HALF)
        return self._stem(host, int(rng.choice([-1, 1])), along, rng)

    def _cap(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        """A new profile across `host`'s end: an L-corner when flush, a T when further along."""
        host = self._host(parts, rng)
        axis = self._axis(host)
        u, n = _AXES[axis], _AXES[1 - axis]
        end = int(rng.choice([-1, 1]))
        cap = self._profile(rng, 0.0, 0.0, 1 - axis)
        half_span = cap.type.length / 2 - HALF
        if rng.random() < float(self.cfg["flush_corner_share"]):
            along = half_span * int(rng.choice([-1, 1]))
        else:
            along = self._along(rng, half_span)
        centre = np.asarray(host.xy) + u * end * (host.type.length / 2 + HALF) + n * along
        return Part("new", cap.type, planar_pose(centre[0], centre[1], 1 - axis))

    def _end_to_end(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        host = self._host(parts, rng)
        axis = self._axis(host)
        new = self._profile(rng, 0.0, 0.0, axis)
        end = int(rng.choice([-1, 1]))
        centre = np.asarray(host.xy) + _AXES[axis] * end * (host.type.length + new.type.length) / 2
        return Part("new", new.type, planar_pose(centre[0], centre[1], axis))

    def _rail(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        """A stem parallel to an existing T-stem off the same bar, at a sampled gap beside it."""
        joints = end_joints(parts, self.tolerance)
        if not joints:
            return None
        joint = joints[rng.integers(len(joints))]
        stem, host = parts[joint.part], parts[joint.host]
        u = _AXES[self._axis(host)]
        along = float((np.asarray(stem.xy) - np.asarray(host.xy)) @ u)
        side = -int(np.sign(np.asarray(joint.direction) @ _AXES[1 - self._axis(host)]))
        lo, hi = self.cfg["gap_mm"]
        kind = None
        if rng.random() < float(self.cfg["narrow_gap_share"]):
            gap = int(rng.integers(int(lo), int(self.finger_mm)))
            # Two equally long stems a finger-gap apart block each other both ways.
            if rng.random() >= float(self.cfg["narrow_same_length_share"]):
                other = {PartType.PROFILE_200: PartType.PROFILE_300}
                kind = other.get(stem.type, PartType.PROFILE_200)
            else:
                kind = stem.type
        else:
            gap = int(rng.integers(int(self.finger_mm) + 1, int(hi) + 1))
        step = PROFILE_SECTION_MM + gap
        return self._stem(host, side, along + step * int(rng.choice([-1, 1])), rng, kind)

    def _bracket(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        """An angle bracket in a free inner corner of a T or L joint (it needs both profiles)."""
        joints = end_joints(parts, self.tolerance)
        corners = []
        for j in joints:
            stem, host = parts[j.part], parts[j.host]
            d = np.asarray(j.direction, dtype=float)
            t = np.array([-d[1], d[0]])
            face = np.asarray(stem.xy) + d * stem.type.length / 2
            for s in (-1, 1):
                corner = face + t * s * HALF
                legs = frozenset({tuple(int(v) for v in t * s), tuple(int(v) for v in -d)})
                pose = planar_pose(corner[0], corner[1], _BRACKET_TURNS[legs])
                corners.append((Part("new", PartType.BRACKET, pose), stem, host))
        rng.shuffle(corners)
        for bracket, stem, host in corners:
            if (
                parts_contact(bracket, stem, self.tolerance) >= BRACKET_LEG_MM - self.tolerance
                and parts_contact(bracket, host, self.tolerance) >= BRACKET_LEG_MM - self.tolerance
                and not any(parts_overlap(bracket, p, self.tolerance) for p in parts)
            ):
                return bracket
        return None
