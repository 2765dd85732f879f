"""Frames that have an order: the feasible-frame generator (docs/planning.md, "Large frames").

Most large generated frames have no order, so a benchmark of the search on feasible frames
needs a generator that yields feasible ones. Up to `truth_limit` parts the ground truth
decides (rejection: frames are drawn until one is feasible); above it, where the brute force
cannot go, the verified search decides, ordered by the contact heuristic under a budget of
step checks (not seconds), so the frames are deterministic per seed on any machine. A frame
built in sections (simulator=large_frames) is verified as it grows, after each section: a
section that leaves no verified order is grown again, not the whole frame. Only a verified
frame is returned, so every frame has an order; the search's verdict on it is what a planner
is measured against.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from grace.domain.assembly import Assembly
from grace.errors import UserError
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.search import Outcome, VerifiedSearch
from grace.planning.sequences import Scorer
from grace.simulation.simulator import Simulator


@dataclass(frozen=True)
class FeasibleFrames:
    """`search` (with `checks_per_part` × N step checks) ordered by `scorer` decides above
    `truth_limit` parts, the ground truth up to it; `tries` frames are drawn at most."""

    search: VerifiedSearch
    scorer: Scorer
    truth_limit: int = 16
    checks_per_part: int = 20
    tries: int = 100

    def verified(self, simulator: Simulator, assembly: Assembly) -> bool:
        """Whether `assembly` has an order: by the ground truth or found by the search."""
        if assembly.n_parts <= self.truth_limit:
            return simulator.truth(assembly).feasible
        search = replace(
            self.search, k=1, max_seconds=None, max_checks=self.checks_per_part * assembly.n_parts
        )
        steps = SimulatorSteps(simulator, assembly)
        return search.plan(self.scorer, assembly, steps).outcome == Outcome.verified

    def draw(self, simulator: Simulator, n_parts: int, rng: np.random.Generator) -> Assembly:
        """A frame of `n_parts` with an order (deterministic in `rng`'s state)."""
        accepted: list[Assembly] = []

        def grows(frame: Assembly) -> bool:
            ok = self.verified(simulator, frame)
            if ok:
                accepted.append(frame)
            return ok

        for _ in range(self.tries):
            frame = simulator.generate(n_parts, rng, grows)
            if (accepted and accepted[-1] == frame) or self.verified(simulator, frame):
                return frame
        raise UserError(
            f"no feasible {n_parts}-part frame in {self.tries} draws; fix: a smaller size, or "
            "simulator=large_frames above 16 parts"
        )
