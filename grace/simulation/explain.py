"""Why a part can or cannot be placed in a state: a small typed verdict (docs/world.md, "Explain").

Built from the same cached options as the ground truth, so a verdict never disagrees with the
labels; naming the robot body and the part it hits is a readout of the option's blocker masks.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import mask_to_parts
from grace.domain.motion import Motion
from grace.simulation.cell_config import RULES
from grace.simulation.ground_truth import Fixation
from grace.simulation.robot_cell import BODIES, KINDS, RULE_OF_BODY, PlacementOption, category

_BODY_NAMES = {
    "joint": "T-slot connector",
    "finger": "finger",
    "palm": "palm",
    "held_part": "held part",
    "arm_column": "arm link 1 (column)",
    "arm_upper": "arm link 2 (upper arm)",
    "arm_forearm": "arm link 3 (forearm)",
    "arm_wrist": "arm link 4 (wrist)",
}


@dataclass(frozen=True)
class Block:
    """One reason a candidate fails: the rule, the robot-side body, what it hits."""

    rule: str
    body: str
    """'finger', 'palm', 'held part', 'slide corridor', 'arm link k (...)', 'T-slot connector',
    'arm k' (reach), 'arm k links' (table or itself)."""
    part: int | None
    """The part hit (for a clamp: the part it holds); None for reach and table/self hits."""
    obstacle: str
    """'part', 'clamp' (a solid of part `part`'s clamp: its base, there from the start, what the
    open clamp holds out, there until `part` is placed, or what closing brings, an arm or a
    handle, there once `part` is placed), 'out of reach' or 'table or arm itself'."""


@dataclass(frozen=True)
class Candidate:
    """One (arm, IK branch, grasp, motion) option and what blocks it in the state asked."""

    arm: int
    branch: int
    grasp: int
    motion: int
    motion_kind: str
    blocks: tuple[Block, ...]

    @property
    def feasible(self) -> bool:
        return not self.blocks


@dataclass(frozen=True)
class Verdict:
    """Placing `part` in state `placed`: feasible or not, the deciding rule, every candidate.

    `rule` is None if feasible, "fixation" if fixation fails, else the first rule (in
    `RULES` order) whose switching off alone would make the placement feasible, or
    "compound" if no single rule does. `used` is the first feasible candidate."""

    part: int
    placed: int
    feasible: bool
    rule: str | None
    candidates: tuple[Candidate, ...]

    @property
    def used(self) -> Candidate | None:
        return next((c for c in self.candidates if c.feasible), None)


def candidate_blocks(
    option: PlacementOption, motion: Motion, placed: int, rules: Collection[str]
) -> tuple[Block, ...]:
    """What stops one option in state `placed` under the active `rules`."""
    blocks: list[Block] = []
    if not option.reachable and "reach" in rules:
        blocks.append(Block("reach", f"arm {option.arm}", None, "out of reach"))
    if not option.arm_clear and "arm_links" in rules:
        blocks.append(Block("arm_links", f"arm {option.arm} links", None, "table or arm itself"))
    for body in BODIES:
        for kind in KINDS:
            rule = RULE_OF_BODY[body] if kind == "part" else "clamps"
            if RULE_OF_BODY[body] not in rules or rule not in rules:
                continue
            # A clamp's base stands from the start, its open solids until its part is placed
            # (its own part's while that part is placed), a part and its closed clamp once placed.
            standing = {"post": -1, "open": ~placed}.get(kind, placed)
            hit = option.masks[category(body, kind)] & standing
            name = _BODY_NAMES[body]
            if body == "held_part" and motion.kind != "top_down":
                name = "slide corridor"
            obstacle = "part" if kind == "part" else "clamp"
            blocks.extend(Block(rule, name, q, obstacle) for q in mask_to_parts(hit))
    return tuple(blocks)


def explain(
    part: int,
    placed: int,
    options: list[PlacementOption],
    motions: list[Motion],
    fixation: Fixation,
    rules: Collection[str] = RULES,
) -> Verdict:
    """The verdict of placing `part` in state `placed` from the part's cached `options`."""
    active = [r for r in RULES if r in rules]
    candidates = tuple(
        Candidate(
            o.arm,
            o.branch,
            o.grasp,
            o.motion,
            motions[o.motion].kind,
            candidate_blocks(o, motions[o.motion], placed, active),
        )
        for o in options
    )
    fixed = "fixation" not in active or bool(fixation.holds(np.int64(placed), part))
    feasible = fixed and any(c.feasible for c in candidates)
    rule: str | None = None
    if not fixed:
        rule = "fixation"
    elif not feasible:
        rule = next(
            (
                r
                for r in active
                if any(
                    not candidate_blocks(
                        o, motions[o.motion], placed, [x for x in active if x != r]
                    )
                    for o in options
                )
            ),
            "compound",
        )
    return Verdict(part, placed, feasible, rule, candidates)
