"""Closed-form iiwa IK and link points against MuJoCo forward kinematics (rule: reach)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from grace.simulation.kinematics import N_BRANCHES, top_down_rotation
from grace.simulation.robot_cell import RobotCell


@pytest.fixture(scope="module")
def cell(sim_cfg) -> RobotCell:
    return RobotCell(**sim_cfg["cell"])


def _forward(cell: RobotCell, arm: int, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cell.data.qpos[:] = 0.0
    cell.data.qpos[cell._qpos[arm]] = q
    mujoco.mj_kinematics(cell.model, cell.data)
    site = cell.model.site(f"arm{arm}_tcp").id
    return cell.data.site_xpos[site].copy(), cell.data.site_xmat[site].reshape(3, 3).copy()


def test_ik_solutions_reproduce_the_target_in_mujoco(cell):
    rng = np.random.default_rng(0)
    flip = np.diag([-1.0, -1.0, 1.0])  # the gripper is symmetric under a half turn about its axis
    targets = rng.uniform([-0.4, -0.3, 0.0], [0.4, 0.3, 0.12], size=(60, 3))
    covered = 0
    for tcp in targets:
        yaw = rng.uniform(-np.pi, np.pi)
        hit = False
        for arm, kin in enumerate(cell.arms):
            q, ok = kin.top_down_ik(tcp[None], yaw)
            assert q.shape == (N_BRANCHES, 1, 7)
            for branch in np.flatnonzero(ok[:, 0]):
                assert np.all(np.abs(q[branch, 0]) <= kin.limits)
                pos, rot = _forward(cell, arm, q[branch, 0])
                assert np.abs(pos - tcp).max() < 1e-5  # 0.01 mm
                want = top_down_rotation(yaw)
                assert min(np.abs(rot - want).max(), np.abs(rot - want @ flip).max()) < 1e-6
                hit = True
        covered += hit
    assert covered >= 0.95 * len(targets)  # nearly all of the work area is reachable


def test_out_of_reach_targets_are_rejected(cell):
    for kin in cell.arms:
        for tcp in ([1.5, 0.0, 0.02], [0.0, 1.5, 0.02], [*kin.base[:2], 0.02]):
            assert not kin.top_down_ik(np.array([tcp]), 0.0)[1].any()
        assert not kin.within_reach(np.array([[1.5, 0.0, 0.02]])).any()


def test_joint_limits_are_enforced(cell):
    kin = cell.arms[0]
    tcp = np.array([[0.0, 0.0, 0.02]])
    assert kin.top_down_ik(tcp, 0.0)[1].any()
    narrow = dataclasses.replace(kin, limits=np.full(7, np.radians(5.0)))
    assert not narrow.top_down_ik(tcp, 0.0)[1].any()


def test_solutions_along_a_path_vary_smoothly(cell):
    kin = cell.arms[0]
    path = np.column_stack([np.full(30, -0.1), np.full(30, 0.05), np.linspace(0.005, 0.1, 30)])
    q, ok = kin.top_down_ik(path, 0.3)
    branch = np.flatnonzero(ok.all(axis=1))[0]
    assert np.abs(np.diff(q[branch], axis=0)).max() < np.radians(5.0)


def test_link_points_match_mujoco_bodies(cell):
    """The numpy link endpoints the broad phase uses are MuJoCo's body origins."""
    kin = cell.arms[1]
    q, ok = kin.top_down_ik(np.array([[0.1, -0.15, 0.03]]), 0.7)
    for branch in np.flatnonzero(ok[:, 0]):
        points = kin.link_points(q[branch, 0])
        cell.data.qpos[:] = 0.0
        cell.data.qpos[cell._qpos[1]] = q[branch, 0]
        mujoco.mj_kinematics(cell.model, cell.data)
        bodies = [cell.data.xpos[cell.model.body(f"arm1_l{k}").id] for k in (1, 2, 3, 4)]
        np.testing.assert_allclose(points[:4], bodies, atol=1e-9)
        tcp = cell.data.site_xpos[cell.model.site("arm1_tcp").id]
        np.testing.assert_allclose(points[4] - [0, 0, kin.tool_length], tcp, atol=1e-6)
    cell.data.qpos[:] = 0.0
