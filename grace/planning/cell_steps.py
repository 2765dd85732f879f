"""Step checks by the simulator: the robot cell queried lazily, once per part.

The first check of a part runs that part's cell queries (MuJoCo, `RobotCell.placement_options`:
a few to tens of milliseconds) and reads each option's (blockers, needs) pair off them the way
the ground truth does (`OptionTable.blockers`); every later check of that part is bitmask work
plus the fixation rule (grace/planning/step_checks.py, docs/planning.md).
"""

from __future__ import annotations

import numpy as np

from grace.domain.assembly import Assembly
from grace.planning.step_checks import BlockerSteps
from grace.simulation.check import OrderChecker
from grace.simulation.ground_truth import OptionTable
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

    def part_masks(self, part: int) -> list[tuple[int, int]]:
        """The simulator's own (blockers, needs) pairs of the part's usable options under its
        active rules (`OptionTable.blockers`, what the ground truth is enumerated from)."""
        checker = self.checker
        options = checker.options(part)
        if not options:
            return []
        per_part = [options if p == part else [] for p in range(self.n_parts)]
        table = OptionTable.build(checker.assembly, per_part, checker.fixation)
        return [(int(b), int(n)) for b, n in table.blockers(checker.simulator.rules)[part]]

    def fixed(self, states: np.ndarray, part: int) -> np.ndarray:
        if "fixation" not in self.checker.simulator.rules:
            return np.ones(np.shape(states), dtype=bool)
        return self.checker.fixation.holds(states, part)
