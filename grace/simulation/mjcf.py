"""The cell's MuJoCo model, built once per cell config (issue 2).

One compiled model serves every assembly: parts are a pool of box slots in the world body, and the
swept gripper and held part a pool of boxes in one `sweep` body; queries move and resize them
(`model.geom_pos/size`) instead of recompiling XML. Collision filtering via contype/conaffinity
tests only {arm links, swept boxes} against {part slots, table}, plus arm self-collision of
non-adjacent links (adjacent links are parent and child and filtered by MuJoCo).
"""

from __future__ import annotations

import numpy as np

from grace.simulation.cell_config import CellConfig

MM = 1e-3
PART_BIT, TABLE_BIT, SWEEP_BIT = 1, 2, 4
BOXES_PER_SEGMENT = 5
"""Held part (up to two boxes for a bracket) and gripper (two fingers, palm) per swept segment."""
PARK = 100.0
"""Unused slots wait this far (m) from the cell, each at its own spot."""


def arm_bit(arm: int) -> int:
    """Self-collision bit of one arm: its links collide with each other, not with the other arm."""
    return 8 << arm


def part_slot_count(cfg: CellConfig) -> int:
    return 2 * cfg.max_parts


def sweep_slot_count(cfg: CellConfig) -> int:
    return BOXES_PER_SEGMENT * cfg.max_segments


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
    span = (g.max_opening + 2 * g.finger_thickness) * MM / 2
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
    return f"""
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
              <geom type="box" size="{span:.9g} {finger[1]:.9g} {g.palm_height * MM / 2:.9g}"
                    pos="0 0 {l4 + g.palm_height * MM / 2:.9g}" contype="0" conaffinity="0"
                    rgba=".2 .2 .2 1"/>
              <geom type="box" size="{_vec(finger)}" pos="{off:.9g} 0 {fz:.9g}" contype="0"
                    conaffinity="0" rgba=".2 .2 .2 1"/>
              <geom type="box" size="{_vec(finger)}" pos="{-off:.9g} 0 {fz:.9g}" contype="0"
                    conaffinity="0" rgba=".2 .2 .2 1"/>
              <site name="arm{arm}_tcp" pos="0 0 {l4 + tool:.9g}" size="0.005"/>
            </body>
          </body>
        </body>
      </body>
    </body>"""


def build_cell_xml(cfg: CellConfig) -> str:
    """MJCF of the table, the part and sweep slot pools and the arms, in metres."""
    sx, sy, sz = (v * MM for v in cfg.table.size)
    parts = "\n    ".join(
        _box(f"part{i}", park_position(0, i), PART_BIT, 0, ".6 .6 .7 1")
        for i in range(part_slot_count(cfg))
    )
    sweeps = "\n      ".join(
        _box(f"sweep{i}", park_position(1, i), SWEEP_BIT, PART_BIT, ".2 .7 .2 .4")
        for i in range(sweep_slot_count(cfg))
    )
    arms = "".join(_arm(cfg, a) for a in range(len(cfg.bases)))
    return f"""<mujoco model="iiwa14_dual_cell">
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
    <body name="sweep">
      <joint name="sweep" type="slide" axis="0 0 1"/>
      {sweeps}
    </body>{arms}
  </worldbody>
</mujoco>
"""
