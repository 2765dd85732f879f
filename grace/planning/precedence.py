"""Orders that must hold in every order, read off the step checks' masks: a proof of
infeasibility that needs no search (docs/planning.md, "Infeasibility without a search").

Every part must be placed once, in some state, by one of its options. An option is usable in
a state iff its blockers miss the state and its needs lie in it (grace/planning/step_checks.py).
So when every remaining option of part p is blocked by q, p comes before q in every order; when
every one needs q, q comes before p; when fixation lets p go only after one part e (p cannot go
first and e is its only enabler), e comes before p. An option whose blocker must come before p,
or whose need must come after it, can never be used and is dropped; the relations are closed
transitively and the two steps repeated until nothing changes. A part left without an option,
or a part that must come before itself, proves that no order exists. The test is necessary,
not sufficient: it finds no order, it only refutes all of them at once, and it costs each
part's cell queries (which the brute force needs too) and bitmask work, no step checks.
"""

from __future__ import annotations

from grace.domain.assembly import mask_to_parts
from grace.planning.fixation_prior import FixationPrior
from grace.planning.step_checks import BlockerSteps


def _closed(after: list[int]) -> list[int]:
    """`after` closed transitively: q after p and r after q put r after p."""
    out = list(after)
    changed = True
    while changed:
        changed = False
        for p, later in enumerate(out):
            grown = later
            for q in mask_to_parts(later):
                grown |= out[q]
            if grown != later:
                out[p], changed = grown, True
    return out


def refuted(oracle: BlockerSteps, prior: FixationPrior | None = None) -> int | None:
    """A part that no order can place (left without a usable option, or forced before
    itself), None if the test refutes nothing (module docstring)."""
    n = oracle.n_parts
    options = [[(int(b), int(k)) for b, k in oracle.masks(p).tolist()] for p in range(n)]
    fixed = [0] * n  # fixed[p]: parts that precede p by fixation alone
    if prior is not None:
        for p in range(n):
            if not prior.first >> p & 1 and prior.enablers[p].bit_count() == 1:
                fixed[p] = prior.enablers[p]
    while True:
        after = [0] * n
        for p, usable in enumerate(options):
            if not usable:
                return p
            blocked, needed = -1, -1
            for blockers, needs in usable:
                blocked &= blockers
                needed &= needs
            after[p] |= blocked
            for q in mask_to_parts(needed | fixed[p]):
                after[q] |= 1 << p
        after = _closed(after)
        before = [sum(1 << q for q in range(n) if after[q] >> p & 1) for p in range(n)]
        looped = next((p for p in range(n) if after[p] >> p & 1), None)
        if looped is not None:
            return looped
        kept = [
            [(b, k) for b, k in usable if not b & before[p] and not k & after[p]]
            for p, usable in enumerate(options)
        ]
        if kept == options:
            return None
        options = kept
