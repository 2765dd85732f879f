"""Figures of the robot cell (issue 2 targets): query speed and reach coverage; not tests.

Run `python -m grace.simulation.bench [size] [assemblies]` from the repository root: it composes
grace/conf/config.yaml's simulator group and prints the figures as JSON.
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from grace import CONF_DIR
from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.motion import Motion
from grace.simulation.robot_cell import RobotCell
from grace.simulation.simulator import Simulator


def reach_coverage(
    cell: RobotCell, half_extent: float = 400.0, step: float = 20.0, approach: float = 60.0
) -> float:
    """Share of grid points × both profile orientations in the square work area that at least
    one arm reaches with a top-down profile grasp along a drop from `approach` mm."""
    ticks = np.arange(-half_extent, half_extent + step / 2, step)
    hits = total = 0
    for x in ticks:
        for y in ticks:
            for turns in (0, 1):
                total += 1
                probe = Part("probe", PartType.PROFILE_200, planar_pose(x, y, turns))
                hits += _reachable(cell, probe, approach)
    return hits / total


def _reachable(cell: RobotCell, part: Part, approach: float) -> bool:
    drop = Motion("top_down", np.array([[0.0, 0.0, approach], [0.0, 0.0, 0.0]]))
    assembly = Assembly((part,))
    options = cell.placement_options(assembly, 0, [drop])
    return any(o.reachable for o in options)


def cell_benchmark(
    simulator_cfg: Mapping[str, Any], size: int = 7, assemblies: int = 20, seed: int = 0
) -> dict[str, Any]:
    """Median ms per assembly of size `size` for the cell's queries and for the whole ground
    truth, plus the reach figures of the layout."""
    cfg = dict(simulator_cfg)
    cfg.pop("_target_", None)
    cfg.pop("_convert_", None)
    sim = Simulator(**cfg)
    cell = sim.cell
    rng = np.random.default_rng(seed)
    samples = [sim.generate(size, rng) for _ in range(assemblies)]
    cell_ms, label_ms, queries = [], [], []
    for assembly in samples:
        motions = sim.motions(assembly)
        start = time.perf_counter()
        n = sum(
            len(cell.placement_options(assembly, p, motions[p])) for p in range(assembly.n_parts)
        )
        cell_ms.append((time.perf_counter() - start) * 1e3)
        queries.append(n)
        start = time.perf_counter()
        sim.label(assembly)
        label_ms.append((time.perf_counter() - start) * 1e3)
    far = Part("far", PartType.PROFILE_200, planar_pose(1500.0, 0.0))
    return {
        "size": size,
        "assemblies": assemblies,
        "cell_ms_median": statistics.median(cell_ms),
        "label_ms_median": statistics.median(label_ms),
        "options_per_assembly": statistics.mean(queries),
        "us_per_option": 1e3 * sum(cell_ms) / sum(queries),
        "reach_coverage_400mm": reach_coverage(cell),
        "reachable_at_1500mm": _reachable(cell, far, sim.approach_height),
    }


def main() -> None:
    from hydra import compose, initialize_config_dir
    from omegaconf import OmegaConf

    size = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base=None):
        cfg = compose(config_name="simulator/dual_arm")
    simulator = OmegaConf.to_container(cfg.simulator, resolve=True)
    print(json.dumps(cell_benchmark(simulator, size, count), indent=2))


if __name__ == "__main__":
    main()
