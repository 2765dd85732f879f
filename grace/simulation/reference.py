"""A brute-force reference for the ground truth: every documented move, checked uncached.

The enumerator (`feasibility.label`) offers each part a short list of motions
(`joints.insertion_motions`) whose T-slot joint blockers are bitmasks worked out once; a move
missing from that list, or a wrong blocker, makes it call an order impossible that the cell
allows (or the reverse). This reference offers a part, in every state, the top-down drop and a
slide along each of the four world directions with every travel docs/world.md names for it
(the stem's `slide_length`, and `slide_lead` beyond every connector it takes along that
direction or beyond the end of every groove it enters), judges the joint rule connector by
connector from the rule's statement (`joint_allows`), and asks the uncached MuJoCo check
(`RobotCell.check_placement`) for everything else. Its ground truth must equal the
enumerator's; `python -m grace.simulation.reference 5,6,7 20` compares them on generated
assemblies (slow: seconds per assembly). With `--against replay` the labels are compared with
`Simulator.replay` instead (the enumerator's own motions, every step of every order through the
uncached check); `--seed` picks the data seed, and overrides of the simulator group another
cell (`simulator/cell=iiwa14_dual_open_bar`).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

import numpy as np

from grace.domain.assembly import PROFILE_SECTION_MM, Assembly
from grace.domain.motion import Motion
from grace.domain.orders import GroundTruth
from grace.simulation.ground_truth import Fixation
from grace.simulation.joints import (
    Connector,
    EndJoint,
    axis_of,
    connectors,
    end_joints,
    lowered,
    touching,
)
from grace.simulation.simulator import Simulator

HALF = PROFILE_SECTION_MM / 2
DIRECTIONS = ((1, 0), (-1, 0), (0, 1), (0, -1))


def _coordinate(assembly: Assembly, part: int, w: np.ndarray) -> float:
    return float(np.asarray(assembly.parts[part].xy) @ w)


def _along_world(assembly: Assembly, c: Connector, w: np.ndarray) -> float:
    """World coordinate along `w` of connector `c`'s centre."""
    profile = assembly.parts[c.profile]
    return _coordinate(assembly, c.profile, w) + c.along * float(axis_of(profile) @ w)


def joint_allows(
    assembly: Assembly,
    part: int,
    placed: int,
    direction: tuple[int, int] | None,
    travel: float,
    lead: float,
    grooves: Sequence[Connector],
    joints: Sequence[EndJoint],
) -> bool:
    """The joint rule of docs/world.md for one move of `part` (None: top-down), connector by
    connector: every connection with a placed part must be made by a connector entering its
    groove along the groove from an open end, starting `lead` before it, or through the mouth
    while the part carrying it is pushed in horizontally; never vertically."""
    parts = assembly.parts
    if not parts[part].type.is_profile:
        return direction is None  # a bracket is lowered beside its profile (docs/world.md)
    mine = [c for c in grooves if c.profile == part and placed >> c.partner & 1]
    carried = [c for c in grooves if c.partner == part and placed >> c.profile & 1]
    if direction is None:
        return not mine and not carried
    d = np.array(direction, dtype=float)
    w = np.abs(d)
    sigma = float(d @ w)
    own = parts[part]
    for c in mine:  # a placed part's connector must be taken in from this profile's leading end
        if abs(float(axis_of(own) @ w)) < 0.5:
            return False
        gap = sigma * (_coordinate(assembly, part, w) - _along_world(assembly, c, w))
        if travel < gap + own.type.length / 2 + c.half_span + lead - 1e-6:
            return False
    for c in carried:  # this stem's end connector into a placed host's groove
        joint = next(j for j in joints if j.part == part and j.host == c.profile)
        if tuple(direction) == joint.direction:
            if travel < lead - 1e-6:  # through the mouth, from outside the groove
                return False
            continue
        host = parts[c.profile]
        if abs(float(axis_of(host) @ w)) < 0.5:
            return False
        entry = _coordinate(assembly, c.profile, w) - sigma * host.type.length / 2
        clear = sigma * (_coordinate(assembly, part, w) - entry) + HALF + lead
        if travel < clear - 1e-6:
            return False
        closed = any(
            j.part == c.profile
            and j.direction == tuple(int(v) for v in -d)
            and placed >> j.host & 1
            for j in joints
        )
        lo, hi = sorted((_coordinate(assembly, part, w), entry))
        crowded = any(
            o.profile == c.profile
            and o.side == c.side
            and o.partner != part
            and placed >> o.partner & 1
            and min(hi, _along_world(assembly, o, w) + o.half_span)
            - max(lo, _along_world(assembly, o, w) - o.half_span)
            > 0
            for o in grooves
        )
        if closed or crowded:
            return False
    return True


def documented_moves(
    assembly: Assembly, part: int, simulator: Simulator, grooves: Sequence[Connector]
) -> list[tuple[tuple[int, int] | None, float]]:
    """(direction, travel) of every move docs/world.md names for `part`; None = top-down."""
    if not assembly.parts[part].type.is_profile:
        return [(None, 0.0)]
    m = simulator.motion
    moves: list[tuple[tuple[int, int] | None, float]] = [(None, 0.0)]
    own = assembly.parts[part]
    for direction in DIRECTIONS:
        d = np.array(direction, dtype=float)
        w = np.abs(d)
        sigma = float(d @ w)
        travels = {m.slide_length}
        for c in grooves:
            if c.profile == part and abs(float(axis_of(own) @ w)) > 0.5:
                gap = sigma * (_coordinate(assembly, part, w) - _along_world(assembly, c, w))
                travels.add(gap + own.type.length / 2 + c.half_span + m.slide_lead)
            host = assembly.parts[c.profile]
            if c.partner == part and abs(float(axis_of(host) @ w)) > 0.5:
                entry = _coordinate(assembly, c.profile, w) - sigma * host.type.length / 2
                travels.add(sigma * (_coordinate(assembly, part, w) - entry) + HALF + m.slide_lead)
        moves += [(direction, t) for t in sorted(travels) if t > 0]
    return moves


def _carried(
    direction: tuple[int, int] | None, travel: float, heights: Sequence[float]
) -> list[Motion]:
    """One move carried in at each height (the motion's stops as the enumerator's)."""
    kind = "top_down" if direction is None else "slide"
    return [lowered(kind, direction, travel, heights[: k + 1]) for k in range(len(heights))]


def brute_force_truth(simulator: Simulator, assembly: Assembly) -> GroundTruth:
    """The ground truth with every documented move, the joint rule judged per connector and
    every other rule by the uncached MuJoCo check (all rules on)."""
    tolerance = simulator.tolerance
    grooves = connectors(assembly.parts, tolerance)
    joints = end_joints(assembly.parts, tolerance)
    fixation = Fixation.of(assembly, touching(assembly, tolerance))
    moves = [documented_moves(assembly, p, simulator, grooves) for p in range(assembly.n_parts)]
    heights = simulator.carry_heights(assembly)
    lead = simulator.motion.slide_lead

    def can_place(state: int, part: int) -> bool:
        if not fixation.holds(np.int64(state), part):
            return False
        return any(
            joint_allows(assembly, part, state, d, t, lead, grooves, joints)
            and simulator.cell.check_placement(assembly, part, state, motion)
            for d, t in moves[part]
            for motion in _carried(d, t, heights)
        )

    return GroundTruth.explore(assembly.n_parts, can_place)


REFERENCES = {
    "reference": brute_force_truth,
    "replay": Simulator.replayed_truth,
}
"""What the labels are compared with: this module's brute force, or `Simulator.replay` (the
enumerator's motions, every step through the uncached check)."""


def compare(
    simulator: Simulator, assembly: Assembly, against: str = "reference"
) -> dict[str, int | bool]:
    """The enumerator's and a reference's (`REFERENCES`) order counts for one assembly, and
    whether their reachable-state DAGs agree."""
    truth = simulator.label(assembly).truth
    reference = REFERENCES[against](simulator, assembly)
    return {
        "orders": truth.n_orders(),
        f"{against}_orders": reference.n_orders(),
        "agree": truth == reference,
    }


def command_line() -> argparse.ArgumentParser:
    """The arguments of `main`; read them with `parse_intermixed_args` (options may stand
    between the positional arguments)."""
    parser = argparse.ArgumentParser(
        prog="python -m grace.simulation.reference",
        description="Compare the labels of generated frames with a reference (docs/world.md).",
    )
    parser.add_argument("sizes", nargs="?", default="5", help="comma-separated sizes")
    parser.add_argument("count", nargs="?", type=int, default=5, help="frames per size")
    parser.add_argument(
        "overrides",
        nargs="*",
        help="of the simulator group, e.g. simulator/cell=iiwa14_dual_open_bar",
    )
    parser.add_argument("--against", choices=sorted(REFERENCES), default="reference")
    parser.add_argument("--seed", type=int, default=0, help="the data seed (dataset.seed)")
    return parser


def main() -> None:
    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException
    from hydra.utils import instantiate

    from grace import CONF_DIR
    from grace.simulation.cell_config import register

    parser = command_line()
    args = parser.parse_intermixed_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    register()
    try:
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base=None):
            cfg = compose(config_name="simulator/dual_arm", overrides=args.overrides)
    except HydraException as error:
        fix = "use an option or a key of grace/conf/simulator/ (simulator/cell=<name>)"
        parser.error(f"{str(error).splitlines()[0]}; fix: {fix}")
    simulator = instantiate(cfg.simulator)
    disagree = 0
    for size in sizes:
        for index in range(args.count):
            rng = np.random.default_rng(np.random.SeedSequence([args.seed, size, index]))
            row = {
                "size": size,
                "index": index,
                **compare(simulator, simulator.generate(size, rng), args.against),
            }
            disagree += not row["agree"]
            print(json.dumps(row), flush=True)
    summary = {"assemblies": len(sizes) * args.count, "disagreements": disagree}
    print(json.dumps({**summary, "against": args.against, "overrides": args.overrides}))
    sys.exit(1 if disagree else 0)


if __name__ == "__main__":
    main()
