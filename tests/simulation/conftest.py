"""Shared fixtures: the real simulators composed from the config tree, and hand-built frames.

Tests reach the builders through the `world` fixture (never `import conftest`: the root conftest
shares the module name).
"""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.utils import instantiate
from omegaconf import OmegaConf

from grace import CONF_DIR
from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.simulation.cell_config import register
from grace.simulation.simulator import Simulator


def profile(length: int, x: float, y: float, along_x: bool = False) -> Part:
    kind = PartType.PROFILE_300 if length == 300 else PartType.PROFILE_200
    return Part("p", kind, planar_pose(x, y, 1 if along_x else 0))


def bracket(x: float, y: float, quarter_turns: int = 0) -> Part:
    return Part("b", PartType.BRACKET, planar_pose(x, y, quarter_turns))


def build(*parts: Part) -> Assembly:
    return Assembly(tuple(Part(f"part_{i + 1}", p.type, p.pose) for i, p in enumerate(parts)))


def simulator_config(name: str = "dual_arm", *overrides: str) -> dict:
    """The composed `simulator` group as a plain dict (the group alone: its schemas live in
    the simulation layer, so these tests need no task-layer registration)."""
    register()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(config_name=f"simulator/{name}", overrides=list(overrides))
    GlobalHydra.instance().clear()
    return OmegaConf.to_container(cfg.simulator, resolve=True)


@pytest.fixture(scope="session")
def world() -> SimpleNamespace:
    """Builders for hand-made assemblies."""
    return SimpleNamespace(profile=profile, bracket=bracket, build=build, config=simulator_config)


@pytest.fixture(scope="session")
def sim_cfg() -> dict:
    return simulator_config()


@pytest.fixture(scope="session")
def real_sim(sim_cfg) -> Simulator:
    return instantiate(sim_cfg)
