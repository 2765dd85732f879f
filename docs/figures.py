"""Draw the README's pictures with the real simulator: `python docs/figures.py [out_dir]`.

`infeasibility.png`: hand-built assemblies labelled by the MuJoCo robot cell of
`conf/simulator/dual_arm.yaml`, with each part's slide motion drawn as an arrow and the orders
the simulator found. `topview.png` is the one `python -m grace task=generate` writes into its run
folder.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from hydra import compose, initialize_config_dir
from hydra.utils import instantiate
from matplotlib.figure import Figure

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.sample import LabelledAssembly
from grace.visualisation.topview import draw

CONF = Path(__file__).resolve().parents[1] / "conf"


def profile(length: int, x: float, y: float, along_x: bool = False) -> Part:
    kind = PartType.PROFILE_300 if length == 300 else PartType.PROFILE_200
    return Part("p", kind, planar_pose(x, y, 1 if along_x else 0))


def build(name: str, *parts: Part) -> Assembly:
    named = tuple(Part(f"part_{i + 1}", p.type, p.pose) for i, p in enumerate(parts))
    return Assembly(named, name=name)


CASES = {
    "stems 10 mm apart: no room for the gripper's finger": build(
        "finger gap", profile(300, 0, 0, True), profile(300, -40, 170), profile(200, 10, 120)
    ),
    "stems 60 mm apart: both orders": build(
        "wide gap", profile(300, 0, 0, True), profile(300, -40, 170), profile(200, 60, 120)
    ),
    "equal stems 10 mm apart: whichever comes second is blocked": build(
        "blocked", profile(300, 0, 0, True), profile(200, -30, 120), profile(200, 20, 120)
    ),
    "slide corridor: 3 lies where 1 slides in": build(
        "corridor",
        profile(300, 0, 0, True),
        profile(200, 0, 120),
        profile(300, 120, 170),
        profile(200, 0, 270, True),
    ),
}


def _orders_text(sample: LabelledAssembly) -> str:
    orders = [" ".join(map(str, o)) for o in sample.truth.orders(limit=6)]
    more = sample.truth.n_orders() - len(orders)
    return "orders: " + ("; ".join(orders) or "none") + (f" (+{more})" if more > 0 else "")


def infeasibility_figure(simulator, path: Path) -> None:
    fig = Figure(figsize=(4.0 * len(CASES), 4.8))
    for ax, (caption, assembly) in zip(fig.subplots(1, len(CASES)), CASES.items(), strict=True):
        sample = simulator.label(assembly)
        draw(ax, sample)
        for part, motions in zip(assembly.parts, simulator.motions(assembly), strict=True):
            for motion in motions:
                if motion.kind == "slide":
                    start = part.pose[:2, 3] + np.asarray(motion.waypoints[0][:2])
                    end = part.pose[:2, 3]
                    ax.annotate("", end, start, arrowprops={"arrowstyle": "->", "color": "#b71c1c"})
        ax.set_xlabel(f"{caption}\n{_orders_text(sample)}", fontsize=7)
    fig.suptitle("red arrows: T-slot slide motions; orders as found by the MuJoCo cell", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        cfg = compose("config")
    infeasibility_figure(instantiate(cfg.simulator), out / "infeasibility.png")


if __name__ == "__main__":
    main()
