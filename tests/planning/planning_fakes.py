"""Test helpers: the paper's plain per-prefix recursion (the reference) and fake policies."""

from __future__ import annotations

import numpy as np

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.planning.step_checks import BlockerSteps


def line_assembly(n: int) -> Assembly:
    """N profiles side by side: the planner only needs N, the fake scorers ignore geometry."""
    return Assembly(
        tuple(Part(f"p{i}", PartType.PROFILE_200, planar_pose(60.0 * i, 0.0)) for i in range(n))
    )


class TableScorer:
    """A fake policy with fixed random scores per state, quantised so ties with λ occur."""

    def __init__(self, n: int, seed: int, levels: int = 10):
        rng = np.random.default_rng(seed)
        self.table = rng.integers(0, levels + 1, size=(1 << n, n)) / levels
        self.states = 0

    def __call__(self, assembly, states):
        self.states += len(states)
        return self.table[np.asarray(states)]


def traverse(scorer, assembly, threshold: float):
    """(sequences, probabilities, step scores, dead ends, forward passes), one pass per prefix."""
    n = assembly.n_parts
    out: list[tuple[tuple[int, ...], float, tuple[float, ...]]] = []
    dead: list[tuple[int, ...]] = []
    passes = 0

    def recurse(state: int, prefix: tuple[int, ...], prob: float, steps: tuple[float, ...]):
        nonlocal passes
        if state == (1 << n) - 1:
            out.append((prefix, prob, steps))
            return
        y = np.asarray(scorer(assembly, np.array([state], dtype=np.int64)), dtype=float)[0]
        passes += 1
        branched = False
        for i in range(n):
            if state >> i & 1 or y[i] < threshold:
                continue
            branched = True
            recurse(state | 1 << i, (*prefix, i), prob * float(y[i]), (*steps, float(y[i])))
        if not branched:
            dead.append(prefix)

    recurse(0, (), 1.0, ())
    return out, dead, passes


class MaskSteps(BlockerSteps):
    """A hand-written world for the search: part p can be placed in state S iff fixation holds
    (any part first; later, a part touching a placed one in `touch`) and one of `masks[p]` is
    free in S: a blocker mask that misses S, or a (blockers, needs) pair. `queried` counts the
    parts whose masks were read (the cell queries a simulator would run)."""

    def __init__(self, masks: list[list[int]], touch: list[int] | None = None):
        super().__init__(len(masks))
        self.table = masks
        self.touch = touch
        self.queried = 0

    def part_masks(self, part):
        self.queried += 1
        return [m if isinstance(m, tuple) else (m, 0) for m in self.table[part]]

    def fixed(self, states, part):
        states = np.asarray(states, dtype=np.int64)
        if self.touch is None:
            return np.ones(states.shape, dtype=bool)
        return (states == 0) | ((states & self.touch[part]) != 0)


def fixed_scores(rows: dict[int, list[float]], n: int, default: float = 0.5):
    """StateScores of a fake policy: `rows[state]` where given, else `default` for every part;
    `asked` lists the states scored, in order."""

    def scores(state: int) -> np.ndarray:
        scores.asked.append(state)
        return np.asarray(rows.get(state, [default] * n), dtype=np.float64)

    scores.asked = []
    return scores


def random_world(n: int, rng: np.random.Generator) -> tuple[list[list], list[int]]:
    """Random options (0–3 per part, each blocked by 0–2 others, a third of them needing one
    more part placed first, as an open clamp in the way does) and a random connected contact
    graph."""
    touch = [0] * n
    for p in range(1, n):
        q = int(rng.integers(p))
        touch[p] |= 1 << q
        touch[q] |= 1 << p
    masks = []
    for p in range(n):
        options = []
        for _ in range(int(rng.integers(0, 4))):
            others = [q for q in range(n) if q != p]
            chosen = rng.choice(others, size=int(rng.integers(0, 3)), replace=False)
            blockers = sum(1 << int(q) for q in chosen)
            free = [q for q in others if not blockers >> q & 1]
            if rng.random() < 1 / 3:
                options.append((blockers, 1 << int(rng.choice(free))))
            else:
                options.append(blockers)
        masks.append(options)
    return masks, touch
