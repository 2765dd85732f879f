"""The robot cell's configuration (grace/conf/simulator/cell/*.yaml), checked once and typed.

Every number of the cell lives in the yaml (issue 2): lengths in millimetres, angles in degrees,
as the domain uses; the MuJoCo model converts to metres and radians.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

CONFIG_FILE = "grace/conf/simulator/cell/*.yaml"


@dataclass(frozen=True)
class TableConfig:
    size: tuple[float, float, float]
    """x extent, y extent and thickness; the top is the plane z = 0."""


@dataclass(frozen=True)
class ArmConfig:
    link_lengths: tuple[float, float, float, float]
    """Base → shoulder → elbow → wrist → flange (SPEC §10)."""
    joint_limits: tuple[float, ...]
    """± limit of A1…A7 in degrees."""
    link_radii: tuple[float, float, float, float]
    """Capsule radii of column, upper arm, forearm, wrist."""


@dataclass(frozen=True)
class GripperConfig:
    palm_height: float
    """Flange to the fingers' roots (adapter and palm)."""
    finger_thickness: float
    """Across the opening direction: what a finger needs beside a part."""
    finger_width: float
    """Along the grasped edge."""
    finger_length: float
    max_opening: float
    grasp_height: float
    """Fingertips above the table when holding a profile."""
    bracket_grip_depth: float
    """How far the fingertips reach below a bracket's top when holding it by a leg."""


@dataclass(frozen=True)
class CellConfig:
    table: TableConfig
    arm: ArmConfig
    bases: tuple[tuple[float, float, float, float], ...]
    """Per arm: x, y, z of the A1 axis foot and the yaw (deg) A1 = 0 points to."""
    gripper: GripperConfig
    grasp_fractions: tuple[float, ...]
    """Grasp positions along a profile's axis, as fractions of its length from its −y end."""
    touch_tolerance: float
    """Penetration up to this depth counts as touching, not colliding."""
    arm_sample_step: float
    """Largest TCP step between arm-link collision samples along a motion."""
    max_parts: int
    max_segments: int

    @classmethod
    def parse(cls, cfg: Mapping[str, Any]) -> CellConfig:
        """Typed config from the yaml's keys; one clear error for a missing or unknown key."""
        top = _check(cfg, cls, "")
        nested = {"table": TableConfig, "arm": ArmConfig, "gripper": GripperConfig}
        values = dict(top)
        for key, kind in nested.items():
            values[key] = kind(**{k: _value(v) for k, v in _check(top[key], kind, key).items()})
        values["bases"] = tuple(tuple(float(x) for x in b) for b in top["bases"])
        values["grasp_fractions"] = tuple(float(x) for x in top["grasp_fractions"])
        values["touch_tolerance"] = float(top["touch_tolerance"])
        values["arm_sample_step"] = float(top["arm_sample_step"])
        values["max_parts"] = int(top["max_parts"])
        values["max_segments"] = int(top["max_segments"])
        if any(len(b) != 4 for b in values["bases"]) or not values["bases"]:
            raise ValueError(f"{CONFIG_FILE}: field 'bases' needs one [x, y, z, yaw] per arm")
        if len(values["arm"].joint_limits) != 7:
            raise ValueError(f"{CONFIG_FILE}: field 'arm.joint_limits' needs 7 values (A1…A7)")
        return cls(**values)


def _value(v: Any) -> Any:
    return tuple(float(x) for x in v) if isinstance(v, Sequence) else float(v)


def _check(cfg: Mapping[str, Any], kind: type, prefix: str) -> dict[str, Any]:
    names = {f.name for f in fields(kind)}
    given = dict(cfg)
    where = f"{prefix}." if prefix else ""
    missing, unknown = names - set(given), set(given) - names
    if missing:
        raise ValueError(f"{CONFIG_FILE}: missing field '{where}{sorted(missing)[0]}'; add it")
    if unknown:
        raise ValueError(f"{CONFIG_FILE}: unknown field '{where}{sorted(unknown)[0]}'; remove it")
    return given
