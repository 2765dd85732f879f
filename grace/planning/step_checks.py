"""What a verifying planner asks the simulator: one step check, behind a small interface.

A *simulator step check* is one verdict on one (state, part) pair: can `part` be placed once the
parts of bitmask `state` are placed (docs/planning.md)? It is the unit every planner here is
charged in, and the ground truth's brute force decides one per reachable (state, unplaced part)
pair (`GroundTruth.checks`). A `StepOracle` answers checks, caches them and counts the distinct
ones; the search (grace/planning/search.py) sees only this interface, never the robot cell.

Besides the verdict, a refused step says *what* keeps the part out for good when that is the
case: for each of its options, the placed parts that block it. An option is free in a state iff
its blockers miss the state and its needs (the parts whose open clamps it would hit, there
until they are placed) lie in it (docs/world.md, "How the labels are computed"). Blockers only
accumulate (a placed part is never removed), so once every option has a placed blocker, the
part stays out in every state that holds a set of parts meeting all of them: the planner may
drop all those states without asking again. A step refused for missing needs or by fixation
may pass later: it names no blockers.

`BlockerSteps` decides from per-part (blockers, needs) pairs and a fixation rule, the structure
of the simulator's checks; `grace.planning.cell_steps.SimulatorSteps` gets both from the
simulator.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from grace.domain.orders import GroundTruth


@dataclass(frozen=True)
class StepCheck:
    """The verdict of one (state, part) step.

    `conflicts` (only when refused with every option of the part blocked by placed parts, not
    by fixation alone): per option (class), the placed parts that block it, as bitmasks within
    the state. Obstacles only accumulate, so the part cannot be placed in any state that meets
    every one of them; `blocking_set` picks a set of placed parts that does. None when the step
    is feasible or only fixation refuses it.
    """

    feasible: bool
    conflicts: tuple[int, ...] | None = None


class StepOracle(Protocol):
    """Answers step checks of one assembly; `checks` counts the distinct ones asked so far."""

    n_parts: int

    @property
    def checks(self) -> int: ...

    def check(self, state: int, part: int) -> StepCheck: ...


class CachedSteps(ABC):
    """A `StepOracle` that decides each (state, part) once: a repeated question is free."""

    def __init__(self, n_parts: int) -> None:
        self.n_parts = n_parts
        self._cache: dict[tuple[int, int], StepCheck] = {}

    @property
    def checks(self) -> int:
        return len(self._cache)

    def check(self, state: int, part: int) -> StepCheck:
        if state >> part & 1:
            raise ValueError(f"part {part} is already placed in state {state:#x}")
        key = (state, part)
        found = self._cache.get(key)
        if found is None:
            found = self._cache[key] = self.decide(state, part)
        return found

    @abstractmethod
    def decide(self, state: int, part: int) -> StepCheck:
        """The verdict, computed (called once per distinct pair)."""


def accepted_throughout(sequence: Sequence[int], steps: StepOracle) -> bool:
    """Whether the simulator accepts every step of `sequence` from the empty state: a complete
    sequence is then a verified order (its first refusal ends the checks)."""
    state = 0
    for part in sequence:
        if not steps.check(state, part).feasible:
            return False
        state |= 1 << part
    return True


def blocking_set(conflicts: tuple[int, ...], order: list[int]) -> int:
    """Placed parts meeting every conflict, taken as early in `order` (the parts in the order
    they were placed) as possible: the state stays dead back to where the latest of them was
    placed, so the earlier they are, the further a search may jump back (conflict-directed
    backjumping). Each conflict contributes its earliest part unless an earlier pick meets it;
    conflicts whose earliest part came latest go first, so one late part can meet many."""
    position = {part: i for i, part in enumerate(order)}

    def earliest(conflict: int) -> int:
        return min((p for p in position if conflict >> p & 1), key=position.__getitem__)

    chosen = 0
    for conflict in sorted(conflicts, key=lambda c: -position[earliest(c)]):
        if not conflict & chosen:
            chosen |= 1 << earliest(conflict)
    return chosen


def minimal_masks(masks: list[int]) -> list[int]:
    """`masks` without duplicates and supersets: whether some mask misses a state, and which
    parts meet them all, depend on the minimal ones only."""
    out: list[int] = []
    for m in sorted(set(masks), key=lambda m: (m.bit_count(), m)):
        if not any(o & m == o for o in out):
            out.append(m)
    return out


class BlockerSteps(CachedSteps):
    """Checks from per-part option masks and a fixation rule (the simulator's structure,
    docs/world.md): `part` can be placed in `state` iff fixation holds and one of its options
    is free (its blockers miss `state`, its needs lie in it). Subclasses provide the (blockers,
    needs) pairs (lazily) and fixation."""

    def __init__(self, n_parts: int) -> None:
        super().__init__(n_parts)
        self._masks: dict[int, np.ndarray] = {}

    def masks(self, part: int) -> np.ndarray:
        """The part's (blockers, needs) pairs (k×2 int64), one per usable option class
        (computed once)."""
        if part not in self._masks:
            pairs = np.array(self.part_masks(part), dtype=np.int64)
            self._masks[part] = pairs.reshape(-1, 2)
        return self._masks[part]

    @abstractmethod
    def part_masks(self, part: int) -> list[tuple[int, int]]:
        """(blockers, needs) of the part's usable options (never-usable options left out)."""

    @abstractmethod
    def fixed(self, states: np.ndarray, part: int) -> np.ndarray:
        """Whether fixation lets `part` go in each of the int64 `states` (a scalar works too)."""

    def decide(self, state: int, part: int) -> StepCheck:
        pairs = self.masks(part).tolist()
        unblocked = [needs for blockers, needs in pairs if not blockers & state]
        if any(needs & state == needs for needs in unblocked):
            return StepCheck(bool(self.fixed(np.int64(state), part)))
        if unblocked:  # refused for now: some option waits for parts still to come
            return StepCheck(False)
        return StepCheck(False, tuple(minimal_masks([b & state for b, _ in pairs])))

    def placeable(self, states: np.ndarray, part: int) -> np.ndarray:
        """The verdicts of `part` in many states at once, uncounted and uncached (the brute
        force's vectorised form, `brute_force`)."""
        states = np.asarray(states, dtype=np.int64)
        pairs = self.masks(part)
        if not len(pairs):
            return np.zeros(states.shape, dtype=bool)
        blockers, needs, s = pairs[None, :, 0], pairs[None, :, 1], states[:, None]
        free = (((s & blockers) == 0) & ((s & needs) == needs)).any(axis=1)
        return free & self.fixed(states, part)


def brute_force(oracle: BlockerSteps) -> GroundTruth:
    """Every order, by deciding every reachable (state, unplaced part) pair: the ground truth's
    enumeration (`GroundTruth.explore_many`) on this oracle's masks; its `checks` is the count a
    verifying planner is compared with."""
    return GroundTruth.explore_many(oracle.n_parts, oracle.placeable, naive_checks=False)
