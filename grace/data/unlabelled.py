"""Unlabelled assemblies drawn from the simulator's generator, without their ground truth:
self-training's larger assemblies (grace/tasks/self_train.py, docs/size-generalisation.md).

`simulator.generate` draws the frame only (`simulator.sample` would brute-force its orders too),
from the same per-assembly random stream as the data store (grace/data/store.py,
`assembly_rng`), so assembly `index` of a size here is the assembly `index` of a generated data
set of the same seed. Copies of the reference assemblies (the test ones) are dropped by layout
(`layout_key`), so the test assemblies' ground truth is never read.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from grace.data.distinct import distinct_from
from grace.data.store import assembly_rng
from grace.domain.assembly import Assembly
from grace.domain.canonical import assembly_key
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly


def layout_key(assembly: Assembly) -> str:
    """The canonical form (grace/domain/canonical.py: part types and poses in any numbering)
    without the ground truth: one placeholder truth per size stands in for it. One simulator
    gives one layout one ground truth, so two equal layouts are copies."""
    placeholder = GroundTruth.from_orders(assembly.n_parts, [])
    return assembly_key(LabelledAssembly(assembly, placeholder))


@dataclass(frozen=True)
class Drawn:
    """One drawn assembly and its index in the stream of its size."""

    assembly: Assembly
    index: int

    @property
    def size(self) -> int:
        return self.assembly.n_parts


class UnlabelledDraws:
    """Draws of `simulator` under data seed `seed`, each (size, index) generated once."""

    def __init__(self, simulator: Any, seed: int) -> None:
        self.simulator = simulator
        self.seed = seed
        self._drawn: dict[tuple[int, int], Drawn] = {}

    def draw(self, size: int, index: int) -> Drawn:
        if (size, index) not in self._drawn:
            assembly = self.simulator.generate(size, assembly_rng(self.seed, size, index))
            assembly.name = f"A{size}-{index:06d}"
            self._drawn[size, index] = Drawn(assembly, index)
        return self._drawn[size, index]

    def first(self, sizes: dict[int, int], reference: Sequence[Any]) -> list[Drawn]:
        """The first `sizes[n]` draws of each size n whose layout is no `reference` assembly's
        (labelled or not: only `.assembly` is read), sizes ascending, each in index order."""

        def draws(counts: dict[int, int]) -> list[Drawn]:
            return [self.draw(n, i) for n, c in sorted(counts.items()) for i in range(c)]

        return distinct_from(draws, sizes, reference, key=lambda s: layout_key(s.assembly))

    def batch(self, r: int, sizes: dict[int, int], reference: Sequence[Any]) -> list[Drawn]:
        """Round `r`'s (1-based) new draws: of each size n the draws `(r-1)·sizes[n]` to
        `r·sizes[n] - 1` of :meth:`first`, so no two rounds share an assembly."""
        kept = self.first({n: r * c for n, c in sizes.items()}, reference)
        out = []
        for n, c in sorted(sizes.items()):
            out += [d for d in kept if d.size == n][(r - 1) * c : r * c]
        return out
