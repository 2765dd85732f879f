"""Step checks by the simulator: the robot cell queried lazily, once per part.

The first check of a part runs that part's cell queries (MuJoCo, `RobotCell.placement_options`:
a few to tens of milliseconds) and reads each option's blockers off its verdict with every
other part placed (`grace.simulation.explain.candidate_blocks`); every later check of that part
is bitmask work plus the fixation rule (grace/planning/step_checks.py, docs/planning.md).
"""

from __future__ import annotations

import numpy as np

from grace.domain.assembly import Assembly, full_mask
from grace.planning.step_checks import BlockerSteps
from grace.simulation.check import OrderChecker
from grace.simulation.explain import candidate_blocks
from grace.simulation.simulator import Simulator


class SimulatorSteps(BlockerSteps):
    """Step checks of one assembly by the simulator (the robot cell queried lazily per part).

    `checker` is the simulator's `OrderChecker` of the assembly: the same option cache gives
    verdicts with reasons (`checker.verdict`) and the cell's pose at a step (`checker.pose`)
    for plan.json and the recording.
    """

    def __init__(self, simulator: Simulator, assembly: Assembly) -> None:
        super().__init__(assembly.n_parts)
        self.checker = OrderChecker(simulator, assembly)
        self._others = full_mask(assembly.n_parts)

    def part_masks(self, part: int) -> list[int]:
        checker = self.checker
        others = self._others & ~(1 << part)
        out = []
        for option in checker.options(part):
            blocks = candidate_blocks(
                option, checker.motions[part][option.motion], others, checker.simulator.rules
            )
            if any(b.part is None for b in blocks):
                continue  # out of reach, or the arm hits the table or itself: in every state
            mask = 0
            for block in blocks:
                mask |= 1 << block.part
            out.append(mask)
        return out

    def fixed(self, states: np.ndarray, part: int) -> np.ndarray:
        if "fixation" not in self.checker.simulator.rules:
            return np.ones(np.shape(states), dtype=bool)
        return self.checker.fixation.holds(states, part)
