"""Stand-ins for the data source and trainer so the experiment runs without them in tests."""

from __future__ import annotations

import numpy as np
import torch

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.planning.counting import label_table

TRUTH: dict[str, GroundTruth] = {}  # by assembly name; rebuilt on demand in worker processes
FITS: list[tuple[int, int]] = []  # fits of this process (fold_jobs=1)
SEEDS: list[int] = []  # torch's seed when each fit began


class PuzzleSource:
    """A `dataset` config target: `load()` gives 36 seeded precedence puzzles."""

    def __init__(self, seed: int) -> None:
        self.seed = seed

    def load(self) -> list[LabelledAssembly]:
        return _puzzles(self.seed)


def _puzzles(seed: int) -> list[LabelledAssembly]:
    """Random precedence puzzles of sizes 3–5; some have cycles and so are infeasible."""
    rng = np.random.default_rng(seed)
    data = []
    for i in range(36):
        n = 3 + i % 3
        before = rng.random((n, n)) < 0.3
        truth = GroundTruth.explore(
            n, lambda s, p, b=before, n=n: all(s >> q & 1 for q in range(n) if b[p, q] and q != p)
        )
        parts = tuple(
            Part(f"p{j}", PartType.PROFILE_300, planar_pose(60.0 * j, 10.0 * i)) for j in range(n)
        )
        assembly = Assembly(parts, name=f"s{seed}-a{i}")
        TRUTH[assembly.name] = truth
        data.append(LabelledAssembly(assembly, truth))
    return data


def fit(cfg, train, val, out_dir, callbacks=()):
    FITS.append((len(train), len(val)))
    SEEDS.append(torch.initial_seed())
    return 0.1  # the noise level of the fake policy


def make_scorer(noise):
    """A near-oracle: valid next parts score high, others low, plus seeded noise."""
    rng = np.random.default_rng(0)

    def scorer(assembly, states):
        if assembly.name not in TRUTH:
            _puzzles(int(assembly.name[1 : assembly.name.index("-")]))
        labels = label_table(TRUTH[assembly.name])[states]
        bits = (labels[:, None] >> np.arange(assembly.n_parts)) & 1
        return np.clip(0.1 + 0.8 * bits + rng.normal(0, noise, bits.shape), 0, 1)

    return scorer
