"""Random fixture frames of aluminium profiles and angle brackets (docs/world.md, "Frames").

A frame grows from one profile by the motifs real fixture frames are made of:

- `t_joint`: a stem whose end meets another profile's long side anywhere along it;
- `cap`: a profile across a free end of another (an L corner when flush with its side, a T
  otherwise); capping the far end of a stem starts a second bar parallel to the first;
- `rung`: a profile spanning the gap between two parallel profiles that face each other at a
  profile's length, both ends in T-slots: flush with their ends it closes a rectangle, set in it
  adds a ladder rung (caps and rungs are flush with probability `flush_share`);
- `comb`: a stem beside an existing stem on the same host, at a gap drawn from `gap_mm`;
- angle brackets in free inner corners of T and L joints (`bracket_share`).

Every contact between two profiles is a T-slot joint whose stem end lies fully on the host's
side; a bracket touches exactly the two profiles of its corner along both legs. Why an order is
infeasible follows from this geometry; no cause has a probability of its own. Every number comes
from the `generator` config (`grace/conf/simulator/generator/frames.yaml`). The result is centred
on the world origin and named part_1..part_N in `canonical_order` (docs/assembly-graph.md).
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
from grace.errors import UserError
from grace.simulation.cell_config import CONFIG_DIR, GeneratorConfig, check_generator, typed
from grace.simulation.joints import axis_of, end_joints, parts_contact, parts_overlap
from grace.simulation.sections import section_sizes, sectioned_frame

HALF = PROFILE_SECTION_MM / 2

# Quarter turns of a bracket whose two legs run along the given pair of world directions.
_BRACKET_TURNS = {
    frozenset({(1, 0), (0, 1)}): 0,
    frozenset({(0, 1), (-1, 0)}): 1,
    frozenset({(-1, 0), (0, -1)}): 2,
    frozenset({(0, -1), (1, 0)}): 3,
}
_LENGTHS = (PartType.PROFILE_200, PartType.PROFILE_300)


class StructureGenerator:
    """Grows connected profile frames; `generate(n, rng)` is deterministic in `rng`'s state."""

    def __init__(self, tolerance: float = 0.5, **cfg: Any) -> None:
        self.cfg = typed(GeneratorConfig, cfg, "generator")
        self.tolerance = tolerance
        self.motifs: dict[str, Callable[[list[Part], np.random.Generator], Part | None]] = {
            "t_joint": self._t_joint,
            "cap": self._cap,
            "rung": self._rung,
            "comb": self._comb,
        }
        check_generator(self.cfg, set(self.motifs))
        weights = np.array([float(self.cfg.motif_weights.get(k, 0.0)) for k in self.motifs])
        self.weights = weights / weights.sum()

    def generate(
        self,
        n_parts: int,
        rng: np.random.Generator,
        section_ok: Callable[[Assembly, int], bool] | None = None,
        frame_ok: Callable[[Assembly], bool] | None = None,
    ) -> Assembly:
        """A connected frame of `n_parts` parts, centred and canonically named; above
        `section_parts`, built in sections whose pieces `section_ok(piece, head)` accepts
        and, if given, that `frame_ok` accepts as the frame grows (grace/simulation/
        sections.py)."""
        if n_parts < 1:
            raise UserError(f"generate: n_parts must be ≥ 1, got {n_parts}")
        cfg = self.cfg
        if cfg.section_parts and n_parts > cfg.section_parts:
            return self._sectioned(n_parts, rng, section_ok or (lambda *_: True), frame_ok)
        for _ in range(cfg.max_restarts):
            parts = self._grow(n_parts, rng)
            if parts is not None:
                return self._finish(parts)
        raise UserError(
            f"{CONFIG_DIR}/generator: no {n_parts}-part frame fits field 'work_area' after "
            f"{cfg.max_restarts} restarts; enlarge work_area or max_attempts"
        )

    def _sectioned(
        self,
        n_parts: int,
        rng: np.random.Generator,
        section_ok: Callable[[Assembly, int], bool],
        frame_ok: Callable[[Assembly], bool] | None,
    ) -> Assembly:
        cfg = self.cfg
        sizes = section_sizes(n_parts, cfg.section_parts)
        for _ in range(cfg.max_restarts):
            parts = sectioned_frame(
                sizes,
                lambda n: self._grow(n, rng),
                lambda piece, head: section_ok(self._named(piece), head),
                rng,
                cfg.section_gap_mm,
                cfg.position_grid_mm,
                self.tolerance,
                cfg.max_restarts,
                cfg.frame_area[0] if cfg.frame_area else np.inf,
                None if frame_ok is None else lambda parts: frame_ok(self._finish(parts)),
            )
            if parts is not None and self._within(parts, cfg.frame_area):
                return self._finish(parts)
        raise UserError(
            f"{CONFIG_DIR}/generator: no {n_parts}-part frame of sections fits field "
            f"'frame_area' after {cfg.max_restarts} restarts; enlarge frame_area or section_parts"
        )

    def _named(self, parts: list[Part]) -> Assembly:
        """`parts` centred and named part_1..part_N in their given order (a section's piece:
        its first part, the host of its link, stays first)."""
        lo, hi = self._extent(parts)
        shift = np.round((lo + hi) / 2)
        named = []
        for i, p in enumerate(parts):
            pose = p.pose.copy()
            pose[:2, 3] -= shift
            named.append(Part(f"part_{i + 1}", p.type, pose))
        return Assembly(tuple(named))

    def _within(self, parts: list[Part], area: list[float]) -> bool:
        lo, hi = self._extent(parts)
        return not area or bool(hi[0] - lo[0] <= area[0] and hi[1] - lo[1] <= area[1])

    def _grow(self, n_parts: int, rng: np.random.Generator) -> list[Part] | None:
        parts = [self._profile(rng, 0.0, 0.0, int(rng.integers(2)))]
        for _ in range(self.cfg.max_attempts):
            if len(parts) == n_parts:
                return parts
            if rng.random() < self.cfg.bracket_share:
                part = self._bracket(parts, rng)
            else:
                kind = list(self.motifs)[rng.choice(len(self.motifs), p=self.weights)]
                part = self.motifs[kind](parts, rng)
            if part is not None and self._fits(parts, part):
                parts.append(part)
        return parts if len(parts) == n_parts else None

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
        tol = self.tolerance
        if any(parts_overlap(new, p, tol) for p in parts):
            return False
        contacts = [p for p in parts if parts_contact(new, p, tol) > 0]
        if not contacts:
            return False
        if new.type.is_profile:
            # Profiles meet only in T-slot joints with the stem's end fully on the host's side.
            if any(not p.type.is_profile or not end_joints([p, new], tol) for p in contacts):
                return False
        elif len(contacts) != 2:
            return False
        return self._within([*parts, new], self.cfg.work_area)

    def _kind(self, rng: np.random.Generator) -> PartType:
        return _LENGTHS[int(rng.random() < self.cfg.profile_300_share)]

    def _profile(self, rng: np.random.Generator, x: float, y: float, axis: int) -> Part:
        return Part("new", self._kind(rng), planar_pose(x, y, axis))

    def _grid(self, rng: np.random.Generator, half_span: float) -> float:
        """A position in [−half_span, half_span] on the `position_grid_mm` raster."""
        grid = self.cfg.position_grid_mm
        steps = int(half_span // grid)
        return float(rng.integers(-steps, steps + 1)) * grid

    @staticmethod
    def _turns(part: Part) -> int:
        return part.quarter_turns % 2

    def _pick(self, parts: list[Part], rng: np.random.Generator) -> Part:
        profiles = [p for p in parts if p.type.is_profile]
        return profiles[rng.integers(len(profiles))]

    def _stem(self, host: Part, side: int, along: float, kind: PartType) -> Part:
        """A profile of `kind` standing on `host`'s long side `side` (±1), `along` mm from its
        centre."""
        u = axis_of(host)
        n = np.array([-u[1], u[0]])
        centre = np.asarray(host.xy) + u * along + n * side * (HALF + kind.length / 2)
        return Part("new", kind, planar_pose(centre[0], centre[1], 1 - self._turns(host)))

    def _t_joint(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        host = self._pick(parts, rng)
        along = self._grid(rng, host.type.length / 2 - HALF)
        return self._stem(host, int(rng.choice([-1, 1])), along, self._kind(rng))

    def _cap(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        """A new profile across a free end of `stem`: flush (L corner) or further along (T)."""
        stem = self._pick(parts, rng)
        u = axis_of(stem)
        end = int(rng.choice([-1, 1]))
        kind = self._kind(rng)
        half_span = kind.length / 2 - HALF
        flush = rng.random() < self.cfg.flush_share
        along = half_span * int(rng.choice([-1, 1])) if flush else self._grid(rng, half_span)
        centre = np.asarray(stem.xy) + u * end * (stem.type.length / 2 + HALF)
        centre = centre + np.array([-u[1], u[0]]) * along
        return Part("new", kind, planar_pose(centre[0], centre[1], 1 - self._turns(stem)))

    def _rung(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        """A profile spanning two parallel profiles that face each other at a profile length."""
        spans = []
        profiles = [p for p in parts if p.type.is_profile]
        for i, a in enumerate(profiles):
            for b in profiles[i + 1 :]:
                if self._turns(a) != self._turns(b):
                    continue
                u = axis_of(a)
                n = np.array([-u[1], u[0]])
                gap = abs(float((np.asarray(b.xy) - np.asarray(a.xy)) @ n)) - 2 * HALF
                kind = next((k for k in _LENGTHS if abs(k.length - gap) < 0.5), None)
                if kind is None:
                    continue
                ca, cb = float(np.asarray(a.xy) @ u), float(np.asarray(b.xy) @ u)
                lo = max(ca - a.type.length / 2, cb - b.type.length / 2)
                hi = min(ca + a.type.length / 2, cb + b.type.length / 2)
                if hi - lo >= 2 * HALF:
                    spans.append((a, b, kind, lo + HALF, hi - HALF))
        if not spans:
            return None
        a, b, kind, lo, hi = spans[rng.integers(len(spans))]
        grid = self.cfg.position_grid_mm
        if rng.random() < self.cfg.flush_share:  # flush with the bars' ends: closed corners
            at = float(rng.choice([lo, hi]))
        else:
            at = lo + float(rng.integers(0, int((hi - lo) // grid) + 1)) * grid
        u = axis_of(a)
        n = np.array([-u[1], u[0]])
        middle = (np.asarray(a.xy) @ n + np.asarray(b.xy) @ n) / 2
        centre = u * at + n * middle
        return Part("new", kind, planar_pose(centre[0], centre[1], 1 - self._turns(a)))

    def _comb(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        """A stem beside an existing stem of the same host, a drawn gap away."""
        joints = end_joints(parts, self.tolerance)
        if not joints:
            return None
        joint = joints[rng.integers(len(joints))]
        host = parts[joint.host]
        u = axis_of(host)
        n = np.array([-u[1], u[0]])
        side = -int(np.sign(np.asarray(joint.direction) @ n))
        lo, hi = self.cfg.gap_mm
        gap = int(rng.integers(int(lo), int(hi) + 1))
        step = (PROFILE_SECTION_MM + gap) * int(rng.choice([-1, 1]))
        return self._stem(host, side, joint.along + step, self._kind(rng))

    def _bracket(self, parts: list[Part], rng: np.random.Generator) -> Part | None:
        """An angle bracket in a free inner corner of a T or L joint, fastened to both."""
        corners = []
        for j in end_joints(parts, self.tolerance):
            stem = parts[j.part]
            d = np.asarray(j.direction, dtype=float)
            t = np.array([-d[1], d[0]])
            face = np.asarray(stem.xy) + d * stem.type.length / 2
            for s in (-1, 1):
                corner = face + t * s * HALF
                legs = frozenset({tuple(int(v) for v in t * s), tuple(int(v) for v in -d)})
                pose = planar_pose(corner[0], corner[1], _BRACKET_TURNS[legs])
                corners.append((Part("new", PartType.BRACKET, pose), stem, parts[j.host]))
        rng.shuffle(corners)
        full = BRACKET_LEG_MM - self.tolerance
        for bracket, stem, host in corners:
            if (
                parts_contact(bracket, stem, self.tolerance) >= full
                and parts_contact(bracket, host, self.tolerance) >= full
                and not any(parts_overlap(bracket, p, self.tolerance) for p in parts)
            ):
                return bracket
        return None
