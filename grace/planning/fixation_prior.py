"""What the fixation rule alone allows, known from the geometry before any step check.

Fixation (docs/world.md, "Rules"): the first part is a profile; a later profile needs a placed
part it touches; a bracket needs a placed profile it joins. From which parts touch, a planner
knows two things without the simulator: whether a part is fixed in a state, and whether a state
can be built at all (some order of its parts satisfies fixation). A step that either fails
leads nowhere, so the verified search tries the steps both allow first, or only those when the
prior is read off the checks' own rule (below; `VerifiedSearch.fixation_prior`); the simulator's
checks still decide every step taken. Backward,
this matters most: taking a part away can leave a rest that no order builds (a bracket whose
profiles are gone, a frame cut in two), which the policy, trained on reachable states only, was
never asked about.

Read off the checks' own rule (`FixationPrior.of_steps`), the prior is a proof, not a guess: a
step it refuses cannot be on any order, and the search drops it without a check. This keeps a
large frame's search out of dead subtrees: near the end of a backward search, a rest that no
order builds has 2^k subsets, each of which a search that only tries such steps last would visit
(docs/planning.md, "Large frames: 20 to 50 parts").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from grace.domain.assembly import Assembly, mask_to_parts
from grace.planning.step_checks import BlockerSteps
from grace.simulation.ground_truth import Fixation
from grace.simulation.joints import touching


@dataclass
class FixationPrior:
    """`first`: the parts fixation lets go first; `enablers[p]`: the parts any one of which,
    placed, fixes p (both read off the simulator's own rule, `Fixation.holds`)."""

    first: int
    enablers: tuple[int, ...]
    _built: dict[int, bool] = field(default_factory=dict, compare=False, repr=False)

    @cached_property
    def enables(self) -> tuple[int, ...]:
        """`enables[q]`: the parts that q, placed, fixes (the transpose of `enablers`)."""
        n = len(self.enablers)
        return tuple(sum(1 << p for p in range(n) if self.enablers[p] >> q & 1) for q in range(n))

    @classmethod
    def of(cls, assembly: Assembly, tolerance: float) -> FixationPrior:
        """The prior of `assembly` from its geometry; `tolerance`: the cell's touch tolerance
        (mm). A guess about the checks: the cell may run with fixation switched off."""
        fixation = Fixation.of(assembly, touching(assembly, tolerance))
        return cls._read(assembly.n_parts, fixation.holds)

    @classmethod
    def of_steps(cls, steps: BlockerSteps) -> FixationPrior:
        """The prior of the checks' own fixation rule (`BlockerSteps.fixed`, everything when
        the cell runs without it): exact, so a step it refuses the check refuses, and a state
        it cannot build no order reaches."""
        return cls._read(steps.n_parts, steps.fixed)

    @classmethod
    def _read(cls, n: int, holds: Callable[[np.ndarray, int], np.ndarray]) -> FixationPrior:
        """Read `first` and `enablers` off `holds(states, part)` (the form of `Fixation.holds`:
        a part goes first or is fixed by any one enabler placed)."""
        singles = np.int64(1) << np.arange(n, dtype=np.int64)
        first = sum(1 << p for p in range(n) if holds(np.int64(0), p))
        enablers = tuple(
            sum(1 << int(q) for q in np.flatnonzero(holds(singles, p)) if q != p) for p in range(n)
        )
        return cls(first, enablers)

    def fixed(self, state: int, part: int) -> bool:
        return bool(self.first >> part & 1 if state == 0 else self.enablers[part] & state)

    def buildable(self, state: int) -> bool:
        """Some order of the parts of `state` satisfies fixation: grown from a part that may go
        first, each next part fixed by those before (adding parts never unfixes one)."""
        if state not in self._built:
            built, tried = state == 0, 0
            for p in mask_to_parts(state & self.first):
                if built:
                    break
                if not tried >> p & 1:  # a start inside a grown set grows no further
                    grown = self._grown(1 << p, state)
                    built, tried = grown == state, tried | grown
            self._built[state] = built
        return self._built[state]

    def _grown(self, start: int, state: int) -> int:
        """The parts of `state` that can follow `start` (a bitmask of one part), breadth
        first along `enables`."""
        grown, stack = start, mask_to_parts(start)
        while stack:
            new = self.enables[stack.pop()] & state & ~grown
            grown |= new
            stack += mask_to_parts(new)
        return grown

    def allows(self, before: int, part: int) -> bool:
        """Fixation alone lets the step place `part` into the state `before`, and some order
        builds `before`."""
        return self.fixed(before, part) and self.buildable(before)
