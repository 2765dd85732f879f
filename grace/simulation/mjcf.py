"""The cell's MuJoCo model, built once per cell config (docs/world.md, "The cell").

One compiled model serves every assembly: parts and their clamps are a pool of box slots in the
world body, and the tool (two fingers, the gripper body and the held part) a pool of boxes in one
`tool` body that three slide joints carry along a motion; queries move and resize them
(`model.geom_pos/size`) instead of recompiling XML. Collision filtering via contype/conaffinity
tests {arm links, tool} against {part slots, table} (the tool skips the table: a held part rests
on it), plus self-collision of an arm's non-adjacent links (adjacent ones are parent and child and
filtered by MuJoCo). The arms' own gripper geoms are drawn only; the tool boxes stand for them.
"""

from __future__ import annotations

import numpy as np

from grace.simulation.cell_config import CellConfig

MM = 1e-3
PART_BIT, TABLE_BIT, TOOL_BIT = 1, 2, 4
PART_BOXES = 2
"""A part's boxes (two for a bracket); its clamp's solids come on top."""
TOOL_BOXES = ("finger0", "finger1", "palm", "held0", "held1")
LINKS = ("column", "upper", "forearm", "wrist")
PARK = 100.0
"""Unused slots wait this far (m) from the cell, each at its own spot."""


def arm_bit(arm: int) -> int:
    """Self-collision bit of one arm: its links collide with each other, not with the other arm."""
    return 8 << arm


def part_slot_count(cfg: CellConfig) -> int:
    """Box slots for `max_parts` parts with the largest clamp type each."""
    return (PART_BOXES + max(len(t.boxes) for t in cfg.clamp.types)) * cfg.max_parts


def park_position(kind: int, index: int) -> np.ndarray:
    return np.array([PARK * (1 + kind), PARK + 2.0 * index, -PARK])


def _vec(v) -> str:
    return " ".join(f"{float(x):.9g}" for x in v)


def _box(name: str, pos, contype: int, conaffinity: int, rgba: str) -> str:
    return (
        f'<geom name="{name}" type="box" pos="{_vec(pos)}" size="0.001 0.001 0.001" '
        f'contype="{contype}" conaffinity="{conaffinity}" rgba="{rgba}"/>'
    )


def _arm(cfg: CellConfig, arm: int) -> str:
    l1, l2, l3, l4 = (x * MM for x in cfg.arm.link_lengths)
    r = [x * MM for x in cfg.arm.link_radii]
    lim = np.radians(cfg.arm.joint_limits)
    x, y, z, yaw = cfg.bases[arm]
    bit = arm_bit(arm)
    g = cfg.gripper
    tool = (g.palm_height + g.finger_length) * MM
    palm = [g.palm_width * MM / 2, g.palm_depth * MM / 2, g.palm_height * MM / 2]
    finger = [g.finger_thickness * MM / 2, g.finger_width * MM / 2, g.finger_length * MM / 2]
    off = (g.max_opening + g.finger_thickness) * MM / 2
    fz = l4 + g.palm_height * MM + finger[2]

    def link(name: str, length: float, radius: float, conaffinity: int) -> str:
        return (
            f'<geom name="arm{arm}_{name}" type="capsule" fromto="0 0 0 0 0 {length:.9g}" '
            f'size="{radius:.9g}" contype="{bit}" conaffinity="{conaffinity}" rgba="1 .5 0 1"/>'
        )

    def joint(k: int, axis: str) -> str:
        return (
            f'<joint name="arm{arm}_a{k}" type="hinge" axis="{axis}" '
            f'range="{-lim[k - 1]:.9g} {lim[k - 1]:.9g}"/>'
        )

    hits = PART_BIT | TABLE_BIT | bit
    # In a top-down grasp the last body's +z points down: the gripper hangs at +z below the flange.
    body = f"""
    <body name="arm{arm}_base" pos="{_vec(np.array([x, y, z]) * MM)}"
          euler="0 0 {np.radians(yaw):.9g}">
      <geom type="cylinder" size="{r[0]:.9g} {z * MM / 2:.9g}" pos="0 0 {-z * MM / 2:.9g}"
            contype="0" conaffinity="0" rgba=".3 .3 .3 1"/>
      <body name="arm{arm}_l1">
        {joint(1, "0 0 1")}
        {link("column", l1, r[0], PART_BIT | bit)}
        <body name="arm{arm}_l2" pos="0 0 {l1:.9g}">
          {joint(2, "0 1 0")}{joint(3, "0 0 1")}
          {link("upper", l2, r[1], hits)}
          <body name="arm{arm}_l3" pos="0 0 {l2:.9g}">
            {joint(4, "0 1 0")}{joint(5, "0 0 1")}
            {link("forearm", l3, r[2], hits)}
            <body name="arm{arm}_l4" pos="0 0 {l3:.9g}">
              {joint(6, "0 1 0")}{joint(7, "0 0 1")}
              {link("wrist", l4, r[3], hits)}
              <geom name="arm{arm}_palm" type="box" size="{_vec(palm)}"
                    pos="0 0 {l4 + palm[2]:.9g}" contype="0" conaffinity="0" rgba=".2 .2 .2 1"/>
              <geom name="arm{arm}_finger0" type="box" size="{_vec(finger)}"
                    pos="{off:.9g} 0 {fz:.9g}" contype="0" conaffinity="0" rgba=".2 .2 .2 1"/>
              <geom name="arm{arm}_finger1" type="box" size="{_vec(finger)}"
                    pos="{-off:.9g} 0 {fz:.9g}" contype="0" conaffinity="0" rgba=".2 .2 .2 1"/>
              <site name="arm{arm}_tcp" pos="0 0 {l4 + tool:.9g}" size="0.005"/>
            </body>
          </body>
        </body>
      </body>
    </body>"""
    if not cfg.track:
        return body
    # On a linear track: a carriage sliding along world y carries the pedestal (docs/world.md).
    lo, hi = (v * MM for v in cfg.track)
    return f"""
    <body name="arm{arm}_carriage">
      <joint name="arm{arm}_track" type="slide" axis="0 1 0" range="{lo:.9g} {hi:.9g}"/>
      {body}
    </body>"""


def build_cell_xml(cfg: CellConfig) -> str:
    """MJCF of the table, the part slot pool, the tool and the arms, in metres."""
    sx, sy, sz = (v * MM for v in cfg.table.size)
    parts = "\n    ".join(
        _box(f"slot{i}", park_position(0, i), PART_BIT, 0, ".6 .6 .7 1")
        for i in range(part_slot_count(cfg))
    )
    tool = "\n      ".join(
        _box(f"tool_{name}", park_position(1, i), TOOL_BIT, PART_BIT, ".2 .7 .2 .5")
        for i, name in enumerate(TOOL_BOXES)
    )
    arms = "".join(_arm(cfg, a) for a in range(len(cfg.bases)))
    return f"""<mujoco model="iiwa14_cell">
  <compiler angle="radian"/>
  <option gravity="0 0 0">
    <!-- Slots move at run time, so the compile-time bounding-volume trees would be stale. -->
    <flag midphase="disable"/>
  </option>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1"/>
    <geom name="table" type="box" size="{sx / 2:.9g} {sy / 2:.9g} {sz / 2:.9g}"
          pos="0 0 {-sz / 2:.9g}" contype="{TABLE_BIT}" conaffinity="0" rgba=".8 .75 .65 1"/>
    {parts}
    <body name="tool">
      <joint name="tool_x" type="slide" axis="1 0 0"/>
      <joint name="tool_y" type="slide" axis="0 1 0"/>
      <joint name="tool_z" type="slide" axis="0 0 1"/>
      {tool}
    </body>{arms}
  </worldbody>
</mujoco>
"""
