"""Closed-form inverse kinematics of the KUKA LBR iiwa 14 R820 for top-down grasps (docs/world.md).

The iiwa is a spherical shoulder (A1, A2), an elbow (A4) and a spherical wrist (A5–A7), with the
redundant joint A3 in between. Fixing A3 = 0 leaves a 6-DoF arm that decouples: A1, A2, A4 put
the wrist centre in place (a planar 2R problem in the vertical plane of A1), A5–A7 then turn the
flange to the wanted orientation (ZYZ Euler angles). This is orders of magnitude faster than
iterating damped least squares on Jacobians, which the ground-truth budget (an A7 assembly in
≤ 50 ms, docs/world.md) needs. Axes are z, y, z, y, z, y, z; in the zero pose the arm stands
upright.

All lengths here are metres; the world frame is the work-area centre on the table, z up.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

N_BRANCHES = 8
"""Shoulder (facing / turned away) × elbow (up / down) × wrist (A5 = 0 / A5 = π) solutions; with
A3 fixed and the tool pointing down the A5 = π twins always exceed the ±170° limit of A5."""


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (angle + np.pi) % (2 * np.pi) - np.pi


# Branch signs (shoulder, elbow, wrist), preferred first: arm facing the target, elbow up.
_SIGNS = np.array(
    [(s, e, w) for s in (1.0, -1.0) for e in (1.0, -1.0) for w in (1.0, -1.0)]
).T.reshape(3, N_BRANCHES, 1)


def top_down_rotation(yaw: float) -> np.ndarray:
    """World orientation of a tool pointing straight down, its x axis at `yaw` in the plane."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])


@dataclass(frozen=True)
class IiwaArm:
    """One arm: link lengths (m), joint limits (rad), base pose and tool length (flange → TCP).

    `lengths` = (base→shoulder, shoulder→elbow, elbow→wrist, wrist→flange); `base` the foot of
    the A1 axis in the world; `base_yaw` the world direction A1 = 0 points to.
    """

    lengths: tuple[float, float, float, float]
    limits: np.ndarray
    base: np.ndarray
    base_yaw: float
    tool_length: float

    @property
    def shoulder(self) -> np.ndarray:
        return self.base + np.array([0.0, 0.0, self.lengths[0]])

    def within_reach(self, tcp: np.ndarray) -> np.ndarray:
        """Cheap pre-reject: the top-down wrist centre lies in the shoulder's reach shell."""
        l2, l3 = self.lengths[1:3]
        wrist = np.atleast_2d(tcp) + np.array([0.0, 0.0, self.tool_length + self.lengths[3]])
        dist = np.linalg.norm(wrist - self.shoulder, axis=-1)
        lo = np.sqrt(l2**2 + l3**2 - 2 * l2 * l3 * np.cos(np.pi - self.limits[3]))
        return (dist <= l2 + l3) & (dist >= lo)

    def top_down_ik(
        self, tcp: np.ndarray, yaw: float | np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """All A3 = 0 solutions putting the TCP at each row of `tcp` (K×3, world m), tool down.

        Returns `q` (8×K×7, rad) and `ok` (8×K): solution exists and is within joint limits.
        The gripper is symmetric under a half turn about its axis, so A7 is taken modulo π and
        never binds.
        """
        tcp = np.atleast_2d(np.asarray(tcp, dtype=float))
        l1, l2, l3, l4 = self.lengths
        c, s = np.cos(self.base_yaw), np.sin(self.base_yaw)
        d = tcp + np.array([0.0, 0.0, self.tool_length + l4 - l1]) - self.base
        vx, vy, height = c * d[:, 0] + s * d[:, 1], c * d[:, 1] - s * d[:, 0], d[:, 2]
        radial = np.hypot(vx, vy)
        cos4 = (radial**2 + height**2 - l2**2 - l3**2) / (2 * l2 * l3)
        exists = np.abs(cos4) <= 1.0
        # The A5 = π twins (odd branches) are solved only if A5's limit lets them be.
        twins = self.limits[4] >= np.pi
        shoulder, elbow, wrist = _SIGNS if twins else _SIGNS[:, ::2]
        q1 = _wrap(np.arctan2(vy, vx) + np.where(shoulder > 0, 0.0, np.pi))
        q4 = elbow * np.arccos(np.clip(cos4, -1.0, 1.0))
        q2 = np.arctan2(shoulder * radial, height) - np.arctan2(
            l3 * np.sin(q4), l2 + l3 * np.cos(q4)
        )
        # Flange orientation relative to link 4, M = (Rz(q1)·Ry(q2+q4))ᵀ·R_tool, written out:
        # with θ = q2 + q4 and α = yaw − base_yaw − q1, M = Ry(−θ)·Rz(α)·diag(1, −1, −1). Its ZYZ
        # angles are A5 = 0, A6 = atan2(sin θ, −cos θ), A7 = π − α, or the same flange pose with
        # A5 = π, A6 negated, A7 + π. A7 is taken modulo π (symmetric gripper).
        theta = q2 + q4
        q5 = np.where(wrist > 0, 0.0, np.pi) + np.zeros_like(theta)
        q6 = wrist * np.arctan2(np.sin(theta), -np.cos(theta))
        q7 = (-(yaw - self.base_yaw - q1) + np.pi / 2) % np.pi - np.pi / 2
        q = np.stack(np.broadcast_arrays(q1, q2, np.zeros_like(q1), q4, q5, q6, q7), axis=-1)
        ok = exists & np.all(np.abs(q) <= self.limits, axis=-1)
        if twins:
            return q, ok
        q_all = np.zeros((N_BRANCHES, *q.shape[1:]))
        ok_all = np.zeros((N_BRANCHES, ok.shape[1]), dtype=bool)
        q_all[::2], ok_all[::2] = q, ok
        return q_all, ok_all

    def link_points(self, q: np.ndarray) -> np.ndarray:
        """Joint centres (…×5×3, m) of the configurations `q` (…×7, A3 = 0, tool pointing down):
        A1 foot, shoulder, elbow, wrist centre, flange. Consecutive pairs are the four link
        capsules (column, upper arm, forearm, wrist) of the MuJoCo model."""
        q = np.asarray(q, dtype=float)
        l1, l2, l3, l4 = self.lengths
        heading = self.base_yaw + q[..., 0]
        radial = np.stack([np.cos(heading), np.sin(heading)], axis=-1)

        def towards(angle: np.ndarray, length: float) -> np.ndarray:
            flat = radial * (length * np.sin(angle))[..., None]
            return np.concatenate([flat, (length * np.cos(angle))[..., None]], axis=-1)

        foot = np.broadcast_to(self.base, (*q.shape[:-1], 3))
        shoulder = foot + np.array([0.0, 0.0, l1])
        elbow = shoulder + towards(q[..., 1], l2)
        wrist = elbow + towards(q[..., 1] + q[..., 3], l3)
        flange = wrist - np.array([0.0, 0.0, l4])
        return np.stack([foot, shoulder, elbow, wrist, flange], axis=-2)
