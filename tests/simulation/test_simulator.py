"""The simulator as a whole: config, determinism, rule switches, replay, explain and pose."""

import itertools
import json

import mujoco
import numpy as np
import pytest
from hydra.utils import instantiate

from grace.errors import UserError
from grace.simulation.cell_config import MECHANISMS, RULES
from grace.simulation.simulator import Simulator

INFO_KEYS = {
    "cause",
    "mechanisms",
    "decisive_rules",
    "robot_pruned",
    "nonlocal_block",
    "orders",
    "fixation_orders",
    "clamps",
    "seconds",
}
RULE_SET = [0, 1, 4, 7, 8, 305]
"""A5 seeds whose labels, together, every rule decides (found by scanning seeds 0…305)."""
ARM = 8
"""An A5 seed where clamps and arm links both decide."""


def a5(sim: Simulator, index: int):
    return sim.generate(5, np.random.default_rng(np.random.SeedSequence([0, 5, index])))


def _check_info(sample) -> None:
    info = sample.info
    assert set(info) == INFO_KEYS
    json.dumps(info)
    assert info["orders"] == sample.truth.n_orders()
    assert set(info["decisive_rules"]) <= set(RULES)
    if sample.truth.feasible:
        assert info["cause"] is None and info["mechanisms"] == []
        assert info["robot_pruned"] == (info["orders"] < info["fixation_orders"])
    else:
        assert info["cause"] in {"reach", "collision", "other"}
        assert set(info["mechanisms"]) <= {*MECHANISMS, "compound"} and info["mechanisms"]


def test_config_builds_the_simulator_deterministically(real_sim):
    assert isinstance(real_sim, Simulator)
    a = real_sim.sample(6, np.random.default_rng(0))
    b = real_sim.sample(6, np.random.default_rng(0))
    assert a.assembly == b.assembly and a.truth == b.truth
    _check_info(a)


@pytest.mark.parametrize("rule", RULES)
def test_switching_a_rule_off_changes_exactly_the_labels_it_decides(real_sim, world, rule):
    off = instantiate(world.config("dual_arm", f"simulator.rules.{rule}=false"))
    changed = 0
    for index in RULE_SET:
        assembly = a5(real_sim, index)
        full, ablated = real_sim.label(assembly), off.label(assembly)
        differs = not full.truth.same_orders(ablated.truth)
        assert differs == (rule in full.info["decisive_rules"]), index
        changed += differs
        if rule != "fixation":  # without fixation any order of a subset may also work
            assert set(full.truth.orders()) <= set(ablated.truth.orders())
    assert changed >= 1


def test_every_listed_order_replays_in_mujoco_and_no_other_does(real_sim):
    """Clamps and arm links decide; all 120 orders through the uncached MuJoCo check."""
    sample = real_sim.label(a5(real_sim, ARM))
    assert {"arm_links", "clamps"} <= set(sample.info["decisive_rules"])
    listed = set(sample.truth.orders())
    assert listed
    for order in itertools.permutations(range(5)):
        assert (real_sim.replay(sample.assembly, order) is None) == (order in listed), order


def test_explain_agrees_with_the_labels_and_names_the_robot_body(real_sim):
    sample = real_sim.label(a5(real_sim, ARM))
    truth, assembly = sample.truth, sample.assembly
    bodies = set()
    for state, placeable in zip(truth.states.tolist(), truth.placeable.tolist(), strict=True):
        for part in range(5):
            if state >> part & 1:
                continue
            verdict = real_sim.explain(assembly, state, part)
            assert verdict.feasible == bool(placeable >> part & 1), (state, part)
            if not verdict.feasible:
                assert verdict.rule in {*RULES, "compound"}
                bodies |= {b.body for c in verdict.candidates for b in c.blocks}
    assert any(b.startswith("arm link") for b in bodies)
    assert {"finger", "T-slot connector"} <= bodies


def test_pose_puts_the_tcp_on_the_grasp(real_sim):
    assembly = a5(real_sim, ARM)
    first = next(iter(real_sim.label(assembly).truth.orders()))
    placed = 0
    for part in first:
        pose = real_sim.pose(assembly, placed, part)
        verdict = real_sim.explain(assembly, placed, part)
        grasp = real_sim.cell.grasps(assembly, part)[verdict.used.grasp]
        arm = verdict.used.arm
        cell = real_sim.cell
        cell.data.qpos[:] = 0.0
        cell.data.qpos[cell._qpos[arm]] = pose.joint_angles[arm]
        mujoco.mj_kinematics(cell.model, cell.data)
        tcp = cell.data.site_xpos[cell.model.site(f"arm{arm}_tcp").id] * 1e3
        np.testing.assert_allclose(tcp, grasp.tcp, atol=0.05)
        assert set(pose.parts) == {*[i for i in range(5) if placed >> i & 1], part}
        placed |= 1 << part
    cell.data.qpos[:] = 0.0


def test_three_simulators_label_the_same_structures(world):
    sims = {name: instantiate(world.config(name)) for name in ("dual_arm", "single_arm", "boxes")}
    assert [s.cell.n_arms for s in sims.values()] == [2, 1, 0]
    assembly = a5(sims["dual_arm"], 305)
    orders = {name: set(s.label(assembly).truth.orders()) for name, s in sims.items()}
    # Fewer arms can only remove options: boxes ⊇ dual ⊇ single.
    assert orders["single_arm"] <= orders["dual_arm"] <= orders["boxes"]
    assert orders["dual_arm"] != orders["boxes"]


def test_unknown_rule_is_a_clear_error(sim_cfg):
    cfg = {**sim_cfg, "rules": {**sim_cfg["rules"], "gravity": True}}
    cfg.pop("_target_"), cfg.pop("_convert_")
    with pytest.raises(UserError, match=r"field 'rules'.*gravity"):
        Simulator(**cfg)
