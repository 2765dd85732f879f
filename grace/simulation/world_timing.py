"""Figures of the world (docs/world.md): ground-truth time per size and reach coverage; not tests.

Run `python -m grace.simulation.world_timing [sizes] [assemblies] [simulator]` from the repository
root, e.g. `python -m grace.simulation.world_timing 7,10,12,16 20`: it composes the simulator group
(`dual_arm` unless named) and prints, per size, the median milliseconds of the cell's queries
and of the whole ground truth (labels, ablations, mechanisms) on one core, as JSON. Time it
under the shared CPU lock.
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from typing import Any

import numpy as np

from grace import CONF_DIR
from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.motion import Motion
from grace.simulation.cell_config import register
from grace.simulation.robot_cell import RobotCell
from grace.simulation.simulator import Simulator


def reach_coverage(
    cell: RobotCell, half_extent: float = 400.0, step: float = 40.0, approach: float = 60.0
) -> float:
    """Share of grid points × both profile orientations in the square work area that at least
    one arm reaches with a top-down profile grasp along a drop from `approach` mm (a carry
    height)."""
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
    options = cell.placement_options(Assembly((part,)), 0, [drop])
    return any(o.reachable for o in options)


def size_benchmark(sim: Simulator, size: int, assemblies: int, seed: int = 0) -> dict[str, Any]:
    """Median ms per assembly of `size` for the cell's queries and for the ground truth."""
    rng = np.random.default_rng(seed)
    samples = [sim.generate(size, rng) for _ in range(assemblies)]
    cell_ms, label_ms, options = [], [], []
    for assembly in samples:
        motions = sim.motions(assembly)
        start = time.perf_counter()
        scene = sim.cell.scene(assembly)
        n = sum(len(sim.cell.part_options(scene, p, motions[p])) for p in range(size))
        cell_ms.append((time.perf_counter() - start) * 1e3)
        options.append(n)
        start = time.perf_counter()
        sim.label(assembly)
        label_ms.append((time.perf_counter() - start) * 1e3)
    return {
        "size": size,
        "assemblies": assemblies,
        "cell_ms_median": statistics.median(cell_ms),
        "ground_truth_ms_median": statistics.median(label_ms),
        "ground_truth_ms_max": max(label_ms),
        "options_per_assembly": statistics.mean(options),
    }


def main() -> None:
    from hydra import compose, initialize_config_dir
    from hydra.utils import instantiate

    sizes = [int(s) for s in (sys.argv[1] if len(sys.argv) > 1 else "7").split(",")]
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    name = sys.argv[3] if len(sys.argv) > 3 else "dual_arm"
    register()  # the simulator group alone: its schemas live in this layer
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base=None):
        cfg = compose(config_name=f"simulator/{name}")
    sim = instantiate(cfg.simulator)
    report: dict[str, Any] = {"simulator": name}
    report["sizes"] = [size_benchmark(sim, size, count) for size in sizes]
    if sim.cell.n_arms:
        # A lone profile gets the first clamp type: its carry heights are the cell's lowest
        # (above the bases) and highest (above the tallest clamp solid).
        lone = Assembly((Part("lone", PartType.PROFILE_200, planar_pose(0.0, 0.0)),))
        heights = sim.carry_heights(lone)
        report["reach_coverage_400mm"] = {
            f"carried_at_{h:g}mm": reach_coverage(sim.cell, approach=h) for h in heights
        }
        far = Part("far", PartType.PROFILE_200, planar_pose(1500.0, 0.0))
        report["reachable_at_1500mm"] = _reachable(sim.cell, far, heights[0])
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
