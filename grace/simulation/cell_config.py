"""Typed configs of the simulator group, registered with Hydra's ConfigStore as schemas.

The yaml files under `grace/conf/simulator/` extend these nodes (`defaults: [schema, _self_]`),
so Hydra rejects an unknown or missing key, or a value of the wrong type, when it composes the
config. The simulator receives plain values from `hydra.utils.instantiate(cfg.simulator)` and
turns them back into these dataclasses with :func:`typed`, which applies the same schema to
configs built in code. Only checks a type cannot express stay hand-written (`check_*`), each one
line naming the key and the fix (`grace.errors.UserError`).

Lengths are millimetres and angles degrees, as the domain uses; the MuJoCo model converts to
metres and radians. The cell's facts and every rule are described in docs/world.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, TypeVar

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from grace.errors import UserError
from grace.roles import WEIGHTS

CONFIG_DIR = "grace/conf/simulator"

RULES = ("fixation", "joints", "fingers", "palm", "held_part", "arm_links", "clamps", "reach")
"""The rules of the world (docs/world.md, "Rules"); each can be switched off alone."""

MECHANISMS = (
    "frame_closing",
    "slide_corridor",
    "narrow_rails",
    "crowded_grasp",
    "bracket_corner",
    "clamp",
    "arm",
    "reach",
)
"""Physically distinct ways an assembly becomes infeasible (docs/world.md, "Mechanisms")."""


@dataclass
class TableConfig:
    size: list[float] = MISSING
    """x extent, y extent and thickness; the top is the plane z = 0."""


@dataclass
class ArmConfig:
    link_lengths: list[float] = MISSING
    """Base → shoulder → elbow → wrist → flange of the iiwa 14 R820 (docs/world.md)."""
    joint_limits: list[float] = MISSING
    """± limit of A1…A7 in degrees."""
    link_radii: list[float] = MISSING
    """Capsule radii of column, upper arm, forearm, wrist."""


@dataclass
class GripperConfig:
    palm_height: float = MISSING
    """Flange to the fingers' roots (adapter and gripper body)."""
    palm_width: float = MISSING
    """Gripper body across the opening direction."""
    palm_depth: float = MISSING
    """Gripper body along the grasped edge."""
    finger_thickness: float = MISSING
    """Across the opening direction: what a finger needs beside a part."""
    finger_width: float = MISSING
    """Along the grasped edge."""
    finger_length: float = MISSING
    max_opening: float = MISSING
    grasp_height: float = MISSING
    """Fingertips above the table when holding a profile."""
    bracket_grip_depth: float = MISSING
    """How far the fingertips reach below a bracket's top when holding it across a leg."""


CLAMP_STATES = ("always", "open", "closed")
"""When a clamp box stands in the cell: at every step, until its profile is placed (the clamp
open), or once its profile is placed and the gripper has left (the clamp closed)."""


@dataclass
class ClampBoxConfig:
    """One solid of a clamp, in the frame of its spot beside the profile (docs/world.md)."""

    when: str = MISSING
    """One of `CLAMP_STATES`."""
    along: list[float] = MISSING
    """[from, to] along the profile, from the clamp's centre line."""
    out: list[float] = MISSING
    """[from, to] out from the profile's side face (negative: over the profile)."""
    z: list[float] = MISSING
    """[bottom, top] above the table."""


@dataclass
class ClampTypeConfig:
    """A clamp model: its solids; the first one stands at every step (its base on the plate)."""

    name: str = MISSING
    boxes: list[ClampBoxConfig] = MISSING


@dataclass
class ClampConfig:
    """The fixture's clamps, one per profile (docs/world.md, "The cell")."""

    types: list[ClampTypeConfig] = MISSING
    """The designer's choices in its order of preference: a profile gets the first type whose
    footprint fits a spot beside it with a finger's room, else the last type on any free spot."""
    grid: float = MISSING
    """Candidate clamp positions along a profile are multiples of this."""


@dataclass
class CellConfig:
    table: TableConfig = field(default_factory=TableConfig)
    arm: ArmConfig = field(default_factory=ArmConfig)
    bases: list[Any] = MISSING
    """Per arm: x, y, z of the A1 axis foot and the yaw (deg) A1 = 0 points to; [] = no robot."""
    gripper: GripperConfig = field(default_factory=GripperConfig)
    clamp: ClampConfig = field(default_factory=ClampConfig)
    grasp_fractions: list[float] = MISSING
    """Grasp positions along a profile's axis, as fractions of its length from its −y end."""
    touch_tolerance: float = MISSING
    """Penetration up to this depth counts as touching, not colliding."""
    arm_sample_step: float = MISSING
    """Largest TCP step between arm-link collision samples along a motion."""
    max_branches: int = MISSING
    """IK branches (shoulder × elbow) tried per arm and option, preferred first."""
    max_parts: int = MISSING
    """Part slots of the compiled MuJoCo model (each part has its boxes and its clamp's)."""
    track: list[float] = field(default_factory=list)
    """[from, to] travel (mm, along world y from its base) of a linear track under every arm;
    [] = fixed pedestals. On a track, an arm's carriage stops opposite the grasp before the
    part is carried in and stays there along the motion (docs/world.md, "Large frames")."""


@dataclass
class MotionConfig:
    slide_length: float = MISSING
    """Last stretch a profile slides along its own axis into a T-slot joint."""
    slide_lead: float = MISSING
    """A profile sliding onto placed connectors starts this far before the first one it takes."""
    approach_clearance: float = MISSING
    """A part is carried in above the tallest obstacle of the cell (parts and every clamp solid
    of the frame's fixture) and lowered from this far above it."""


@dataclass
class GeneratorConfig:
    profile_300_share: float = MISSING
    """Share of 300 mm profiles (the rest are 200 mm)."""
    motif_weights: dict[str, float] = MISSING
    """Relative weights of the ways a frame grows (docs/world.md, "Frames")."""
    flush_share: float = MISSING
    """Probability that a cap or a rung is flush with the ends it meets (a closed corner)."""
    bracket_share: float = MISSING
    """Probability that a growth step puts an angle bracket into a free inner corner."""
    gap_mm: list[int] = MISSING
    """Gap between neighbouring parallel stems of a comb: [narrowest, widest]."""
    position_grid_mm: float = MISSING
    work_area: list[float] = MISSING
    """The structure's bounding box must fit [width x, depth y], centred on the origin."""
    max_attempts: int = MISSING
    max_restarts: int = MISSING
    section_parts: int = 0
    """Frames of more parts are built in sections of at most this many, joined by links
    (grace/simulation/sections.py); 0 = every frame grown whole, `work_area` its box."""
    section_gap_mm: float = 100.0
    """Room between two sections apart from their link."""
    frame_area: list[float] = field(default_factory=list)
    """A sectioned frame's box [x, y] (each section's is `work_area`); [] = no bound."""


@dataclass
class SimulatorConfig:
    _target_: str = field(default="grace.simulation.simulator.Simulator", metadata=WEIGHTS)
    _convert_: str = field(default="all", metadata=WEIGHTS)
    cell: CellConfig = field(default_factory=CellConfig, metadata=WEIGHTS)
    generator: GeneratorConfig = field(default_factory=GeneratorConfig, metadata=WEIGHTS)
    motion: MotionConfig = field(default_factory=MotionConfig, metadata=WEIGHTS)
    rules: dict[str, bool] = field(
        default_factory=lambda: dict.fromkeys(RULES, True), metadata=WEIGHTS
    )


def simulator_schemas() -> dict[str, type]:
    """`<group>/<name>` → schema, of the schemas the simulator yaml files extend."""
    return {
        "simulator": SimulatorConfig,
        "simulator/cell": CellConfig,
        "simulator/generator": GeneratorConfig,
    }


def register() -> None:
    """Store the schemas the simulator yaml files extend (idempotent; also run on import)."""
    store = ConfigStore.instance()
    for path, node in simulator_schemas().items():
        group, _, name = f"schema/{path}".rpartition("/")
        store.store(group=group, name=name, node=node)


T = TypeVar("T")


def typed(kind: type[T], values: Any, key: str) -> T:
    """`values` (a mapping) checked against the schema `kind` and returned as a `kind`.

    One line naming the config key on an unknown, missing or mistyped field.
    """
    if isinstance(values, kind):
        return values
    try:
        merged = OmegaConf.merge(OmegaConf.structured(kind), values)
        return OmegaConf.to_object(merged)  # type: ignore[return-value]
    except OmegaConfBaseException as error:
        where = f"{key}.{error.full_key}" if getattr(error, "full_key", None) else key
        reason = str(error).splitlines()[0]
        raise UserError(
            f"{CONFIG_DIR}: field '{where}': {reason}; fix it to match {kind.__name__}"
        ) from None


def check_cell(cfg: CellConfig) -> None:
    """Physical checks of the cell a type cannot express."""
    if any(len(b) != 4 for b in cfg.bases):
        raise UserError(f"{CONFIG_DIR}/cell: field 'bases' needs one [x, y, z, yaw] per arm")
    if len(cfg.arm.joint_limits) != 7 or len(cfg.arm.link_lengths) != 4:
        raise UserError(
            f"{CONFIG_DIR}/cell: fields 'arm.joint_limits' / 'arm.link_lengths' need 7 / 4 values"
        )
    for t in cfg.clamp.types:
        where = f"{CONFIG_DIR}/cell: field 'clamp.types' ({t.name})"
        if not t.boxes or t.boxes[0].when != CLAMP_STATES[0]:
            raise UserError(f"{where}: the first box must be the base, when: {CLAMP_STATES[0]}")
        for b in t.boxes:
            if b.when not in CLAMP_STATES:
                raise UserError(f"{where}: when '{b.when}' is not one of {list(CLAMP_STATES)}")
            if any(len(v) != 2 or v[0] >= v[1] for v in (b.along, b.out, b.z)):
                raise UserError(f"{where}: along, out and z need [from, to] with from < to")
    if cfg.track and (len(cfg.track) != 2 or cfg.track[0] > cfg.track[1]):
        raise UserError(f"{CONFIG_DIR}/cell: field 'track' needs [] or [from, to] with from ≤ to")
    g = cfg.gripper
    if g.palm_width < g.max_opening + 2 * g.finger_thickness:
        raise UserError(
            f"{CONFIG_DIR}/cell: field 'gripper.palm_width' = {g.palm_width} is narrower than "
            f"the open fingers ({g.max_opening} + 2 × {g.finger_thickness}); widen it"
        )


def check_generator(cfg: GeneratorConfig, motifs: set[str]) -> None:
    """Generator checks a type cannot express: known motif names, a sane gap range."""
    unknown = set(cfg.motif_weights) - motifs
    if unknown:
        raise UserError(
            f"{CONFIG_DIR}/generator: field 'motif_weights' has unknown motifs {sorted(unknown)};"
            f" use {sorted(motifs)}"
        )
    lo, hi = cfg.gap_mm
    if not 0 < lo < hi:
        raise UserError(
            f"{CONFIG_DIR}/generator: field 'gap_mm' = [{lo}, {hi}] needs 0 < narrowest < widest"
        )


register()
