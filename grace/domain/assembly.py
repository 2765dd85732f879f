"""The assembly: parts, their surfaces, poses and the pairwise surface relations.

This is the bottom of the data flow (docs/assembly-graph.md): the simulator builds assemblies,
the raw-format reader imports them, the graph builder reads them. Nothing here imports anything
above it.

Conventions (all lengths in millimetres, poses as 4×4 homogeneous matrices in the world frame):
- A part's local frame has its origin at the centre of its footprint on the table (z = 0 is the
  table plane) and z pointing up. Poses are axis-aligned (rotations about z by multiples of 90°).
- Profiles lie along their local y axis: x ∈ [−20, 20], y ∈ [−L/2, L/2], z ∈ [0, 40].
  Surfaces are numbered clockwise in a top view starting from the part's top
  (docs/assembly-graph.md):
  1 = +y end (short), 2 = +x side (long), 3 = −y end (short), 4 = −x side (long).
- An angle bracket is an L in the plane whose two legs run along local +x and +y from its outer
  corner at the origin; its lateral surfaces face the two profiles it joins:
  1 = the face with normal −x (it leans on the profile to its left),
  2 = the face with normal −y (it rests on the profile below it).
- Parts are numbered from the one whose origin is closest to the world origin
  (docs/assembly-graph.md); :func:`canonical_order` gives that order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum, StrEnum

import numpy as np

MIN_PARTS = 2
"""The fewest parts of an assembly to learn or plan: one part has a single order, and the
network normalises each state's part features over its parts (InstanceNorm)."""

PROFILE_SECTION_MM = 40.0
"""Side of the square aluminium-profile section (docs/world.md)."""

BRACKET_LEG_MM = 40.0
"""Length of each leg of the angle bracket, measured from its outer corner."""

BRACKET_THICKNESS_MM = 8.0
"""Wall thickness of the angle bracket."""


class PartType(StrEnum):
    """Part types by their raw names in `assembly.spec` (docs/raw-format.md)."""

    PROFILE_200 = "item_profile_200"
    PROFILE_300 = "item_profile_300"
    BRACKET = "item_angle_bracket"

    @property
    def is_profile(self) -> bool:
        return self is not PartType.BRACKET

    @property
    def length(self) -> float:
        """Length of a profile along its local y axis (the bracket's leg length otherwise)."""
        return {
            PartType.PROFILE_200: 200.0,
            PartType.PROFILE_300: 300.0,
            PartType.BRACKET: BRACKET_LEG_MM,
        }[self]

    @property
    def index(self) -> int:
        """Integer code used as the part-type node feature (docs/assembly-graph.md)."""
        return list(PartType).index(self)


class SurfaceType(IntEnum):
    """The five surface-type classes of docs/assembly-graph.md, used as the surface node feature."""

    P200_SHORT = 0
    P200_LONG = 1
    P300_SHORT = 2
    P300_LONG = 3
    BRACKET_LATERAL = 4


# Local outward normals and face-centre offsets per surface index (1-based), see module docstring.
_PROFILE_NORMALS = ((0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0))
_BRACKET_NORMALS = ((-1.0, 0.0), (0.0, -1.0))


def surface_count(part_type: PartType) -> int:
    return 4 if part_type.is_profile else 2


def surface_type(part_type: PartType, index: int) -> SurfaceType:
    """Surface-type class of surface `index` (1-based) of a part of `part_type`."""
    if part_type is PartType.BRACKET:
        return SurfaceType.BRACKET_LATERAL
    short = index in (1, 3)
    if part_type is PartType.PROFILE_200:
        return SurfaceType.P200_SHORT if short else SurfaceType.P200_LONG
    return SurfaceType.P300_SHORT if short else SurfaceType.P300_LONG


def planar_pose(x: float, y: float, quarter_turns: int = 0) -> np.ndarray:
    """A 4×4 table pose: translation (x, y, 0) mm, rotation of `quarter_turns`·90° about z."""
    c, s = {0: (1, 0), 1: (0, 1), 2: (-1, 0), 3: (0, -1)}[quarter_turns % 4]
    pose = np.eye(4)
    pose[:2, :2] = [[c, -s], [s, c]]
    pose[0, 3], pose[1, 3] = x, y
    return pose


@dataclass(frozen=True)
class Surface:
    """One planar face of a part; `normal` and `center` are in the world frame (mm)."""

    part: int
    index: int
    type: SurfaceType
    normal: tuple[float, float]
    center: tuple[float, float]


@dataclass(frozen=True, eq=False)
class Part:
    """A part instance: raw name, type and its pose in the world (4×4, mm)."""

    name: str
    type: PartType
    pose: np.ndarray

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Part)
            and self.name == other.name
            and self.type is other.type
            and np.array_equal(self.pose, other.pose)
        )

    def __hash__(self) -> int:
        return hash((self.name, self.type))

    @property
    def xy(self) -> tuple[float, float]:
        return float(self.pose[0, 3]), float(self.pose[1, 3])

    @property
    def quarter_turns(self) -> int:
        """Rotation about z in multiples of 90° (poses are axis-aligned)."""
        return round(math.degrees(math.atan2(self.pose[1, 0], self.pose[0, 0])) / 90.0) % 4

    def footprint_boxes(self) -> list[tuple[float, float, float, float]]:
        """Axis-aligned boxes (xmin, ymin, xmax, ymax) in world mm that the part covers."""
        h = PROFILE_SECTION_MM / 2
        if self.type.is_profile:
            local = [(-h, -self.type.length / 2, h, self.type.length / 2)]
        else:
            t, leg = BRACKET_THICKNESS_MM, BRACKET_LEG_MM
            local = [(0.0, 0.0, leg, t), (0.0, 0.0, t, leg)]
        return [self._to_world_box(box) for box in local]

    def _to_world_box(self, box: tuple[float, float, float, float]) -> tuple[float, ...]:
        corners = np.array([[box[0], box[1]], [box[2], box[3]]])
        world = corners @ self.pose[:2, :2].T + self.pose[:2, 3]
        lo, hi = world.min(axis=0), world.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def surfaces(self, part_index: int) -> list[Surface]:
        rot = self.pose[:2, :2]
        origin = self.pose[:2, 3]
        out = []
        for k in range(1, surface_count(self.type) + 1):
            n_local, c_local = self._local_face(k)
            n = rot @ np.asarray(n_local)
            c = rot @ np.asarray(c_local) + origin
            out.append(
                Surface(
                    part=part_index,
                    index=k,
                    type=surface_type(self.type, k),
                    normal=(round(float(n[0])), round(float(n[1]))),
                    center=(float(c[0]), float(c[1])),
                )
            )
        return out

    def _local_face(self, k: int) -> tuple[tuple[float, float], tuple[float, float]]:
        if self.type.is_profile:
            n = _PROFILE_NORMALS[k - 1]
            half = (PROFILE_SECTION_MM / 2, self.type.length / 2)
            return n, (n[0] * half[0], n[1] * half[1])
        n = _BRACKET_NORMALS[k - 1]
        mid = BRACKET_LEG_MM / 2
        return n, ((0.0, mid) if k == 1 else (mid, 0.0))


def surface_relation(a: Surface, b: Surface, same_surface: bool) -> float:
    """Edge feature between two surfaces (paper Sec. III-A; docs/assembly-graph.md).

    0 for the self loop, 1 for two surfaces of the same part, −1 for orthogonal surfaces and the
    distance between the two parallel planes, floored to whole mm as the reference does, otherwise.
    """
    if same_surface:
        return 0.0
    if a.part == b.part:
        return 1.0
    dot = a.normal[0] * b.normal[0] + a.normal[1] * b.normal[1]
    if dot == 0:
        return -1.0
    gap = abs((b.center[0] - a.center[0]) * a.normal[0] + (b.center[1] - a.center[1]) * a.normal[1])
    return float(math.floor(gap + 1e-6))


@dataclass(eq=False)
class Assembly:
    """An assembly of N parts with its surface table and surface-relation matrix.

    `relations[i, j]` is the edge feature between surfaces i and j (docs/assembly-graph.md) in
    the order of :meth:`surfaces`. It is computed from the poses unless given (raw imports carry
    their own `distances.csv` values, which then take precedence for the listed pairs).
    """

    parts: tuple[Part, ...]
    name: str = ""
    relations: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        self.parts = tuple(self.parts)
        if self.relations is None:
            self.relations = self.geometric_relations()

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Assembly)
            and self.parts == other.parts
            and np.array_equal(self.relations, other.relations)
        )

    @property
    def n_parts(self) -> int:
        return len(self.parts)

    def surfaces(self) -> list[Surface]:
        """All surfaces, part by part; computed once per `parts` tuple (graphs ask for them on
        every encoding, and inference latency is part of the product)."""
        cached = self.__dict__.get("_surfaces")
        if cached is None or cached[0] is not self.parts:
            cached = (self.parts, [s for i, p in enumerate(self.parts) for s in p.surfaces(i)])
            self.__dict__["_surfaces"] = cached
        return list(cached[1])

    def surface_names(self) -> list[str]:
        """Raw surface names `<part>_surface_<k>` in surface order (docs/raw-format.md)."""
        return [f"{self.parts[s.part].name}_surface_{s.index}" for s in self.surfaces()]

    def geometric_relations(self) -> np.ndarray:
        surfaces = self.surfaces()
        n = len(surfaces)
        rel = np.zeros((n, n))
        for i in range(n):
            for j in range(n):
                rel[i, j] = surface_relation(surfaces[i], surfaces[j], i == j)
        return rel


def canonical_order(parts: list[Part]) -> list[Part]:
    """Parts sorted by distance of their origin to the world origin, ties by (x, y)
    (docs/assembly-graph.md)."""
    return sorted(parts, key=lambda p: (round(math.hypot(*p.xy), 6), p.xy))


def full_mask(n_parts: int) -> int:
    """Bitmask of the state in which all `n_parts` parts are placed."""
    return (1 << n_parts) - 1


def mask_to_parts(mask: int) -> list[int]:
    """Indices of the parts set in a state bitmask, ascending."""
    return [i for i in range(mask.bit_length()) if mask >> i & 1]
