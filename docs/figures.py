"""Draw the README's pictures with the real simulator: `python docs/figures.py [out_dir]`.

`infeasibility.png`: one panel per infeasibility mechanism (docs/world.md), each an assembly
labelled by the MuJoCo cell of `grace/conf/simulator/dual_arm.yaml`: hand-built frames where a
small one shows the mechanism, otherwise the first generated A7 assembly (seed 0) that only this
mechanism makes infeasible (or, failing that, one it shares with others); plus a feasible
rectangle whose last rung slides in along its hosts' grooves. Slide motions are arrows, clamp
bases hatched. `topview.png` is the one `python -m grace task=generate` writes into its run
folder.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from hydra import compose, initialize_config_dir
from hydra.utils import instantiate
from matplotlib.figure import Figure

from grace import CONF_DIR
from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.sample import LabelledAssembly
from grace.simulation.cell_config import MECHANISMS, register
from grace.visualisation.topview import draw


def profile(length: int, x: float, y: float, along_x: bool = False) -> Part:
    kind = PartType.PROFILE_300 if length == 300 else PartType.PROFILE_200
    return Part("p", kind, planar_pose(x, y, 1 if along_x else 0))


def build(name: str, *parts: Part) -> Assembly:
    named = tuple(Part(f"part_{i + 1}", p.type, p.pose) for i, p in enumerate(parts))
    return Assembly(named, name=name)


HAND = {
    "narrow_rails": (
        "stems 8 mm apart: no room for a finger beside whichever comes first",
        build("rails", profile(300, 0, 0, True), profile(200, -24, 120), profile(200, 24, 120)),
    ),
}
LAST_RUNG = (
    "rectangle (feasible): the last rung slides in along both bars' grooves from their open ends",
    build(
        "rectangle",
        profile(300, 0, 0, True),
        profile(300, 0, 240, True),
        profile(200, -130, 120),
        profile(200, 130, 120),
    ),
)


def _orders_text(sample: LabelledAssembly) -> str:
    orders = [" ".join(map(str, o)) for o in sample.truth.orders(limit=4)]
    more = sample.truth.n_orders() - len(orders)
    return "orders: " + ("; ".join(orders) or "none") + (f" (+{more})" if more > 0 else "")


def _generated(simulator, mechanism: str, size: int = 7, tries: int = 300) -> LabelledAssembly:
    """The first generated assembly that only `mechanism` makes infeasible, else the first that
    it is one of several mechanisms of."""
    shared = None
    for index in range(tries):
        rng = np.random.default_rng(np.random.SeedSequence([0, size, index]))
        sample = simulator.sample(size, rng)
        found = sample.info.get("mechanisms") or []
        if mechanism in found:
            sample.assembly.name = f"A{size}-{index:06d}"
            if found == [mechanism]:
                return sample
            shared = shared or sample
    if shared is None:
        raise LookupError(f"no A{size} assembly in {tries} made infeasible by {mechanism}")
    return shared


def infeasibility_figure(simulator, path: Path) -> None:
    panels: list[tuple[str, LabelledAssembly]] = []
    for mechanism in MECHANISMS:
        if mechanism in HAND:
            caption, assembly = HAND[mechanism]
            panels.append((f"{mechanism}: {caption}", simulator.label(assembly)))
            continue
        try:
            panels.append((f"{mechanism}: generated", _generated(simulator, mechanism)))
        except LookupError as missing:
            print(missing)
    panels.append((LAST_RUNG[0], simulator.label(LAST_RUNG[1])))
    columns = 4
    rows = -(-len(panels) // columns)
    fig = Figure(figsize=(4.2 * columns, 4.6 * rows))
    axes = fig.subplots(rows, columns, squeeze=False)
    for ax, (caption, sample) in zip(axes.flat, panels, strict=False):
        draw(ax, sample)
        motions = simulator.motions(sample.assembly)
        for part, options in zip(sample.assembly.parts, motions, strict=True):
            # A stem's push into its joint(s): the shortest slide that makes all its connections.
            push = simulator.motion.slide_length + 1e-6
            lowest = min(float(m.waypoints[0][2]) for m in options)
            for m in options:
                if m.waypoints[0][2] > lowest:  # the same move from a higher carry height
                    continue
                if m.kind == "slide" and not m.joint_blockers and m.travel <= push:
                    start = part.pose[:2, 3] + np.asarray(m.waypoints[0][:2])
                    arrow = {"arrowstyle": "->", "color": "#b71c1c"}
                    ax.annotate("", part.pose[:2, 3], start, arrowprops=arrow)
        if sample.truth.feasible:  # how the last part of the first order goes in
            order = next(iter(sample.truth.orders()))
            last, placed = order[-1], sum(1 << p for p in order[:-1])
            used = simulator.explain(sample.assembly, placed, last).used
            move = motions[last][used.motion]
            if move.kind == "side_slide":
                end = sample.assembly.parts[last].pose[:2, 3]
                arrow = {"arrowstyle": "->", "color": "#1565c0", "lw": 1.5}
                ax.annotate("", end, end + np.asarray(move.waypoints[0][:2]), arrowprops=arrow)
        ax.set_xlabel(f"{caption}\n{_orders_text(sample)}", fontsize=7)
    for ax in list(axes.flat)[len(panels) :]:
        ax.axis("off")
    fig.suptitle(
        "One panel per infeasibility mechanism, labelled by the MuJoCo cell (docs/world.md); "
        "red arrows: stems sliding into their T-slot joints; blue: a rung sliding along its "
        "hosts' grooves; hatched: clamp bases (a toggle clamp's handle stands on the outer half "
        "of its base once its profile is placed)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=100, bbox_inches="tight")


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent
    register()  # the simulator group alone: its schemas live in the simulation layer
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose("simulator/dual_arm")
    infeasibility_figure(instantiate(cfg.simulator), out / "infeasibility.png")


if __name__ == "__main__":
    main()
