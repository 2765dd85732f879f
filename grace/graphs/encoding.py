"""Node identities of the Assembly Graph and their positional encodings (paper Sec. IV-B, V-D).

Part ids are the canonical part indices (numbered from the part closest to the origin, paper
Sec. V-D; docs/assembly-graph.md); surface ids are the surface's 1-based index on its own part
(clockwise from the part's top), so the id says which side of a part a surface is. Both are
encoded with a 16-d sinusoidal encoding.

The ablation variants of the paper's Table 4 (docs/paper-results.md) are options here, not code
forks:
- `pe`: "sinusoidal" (paper), "random" (fresh N(0,1) values per graph instead of the encoding) or
  "none" (zeros, so the network keeps its shape and parameter count);
- `permute_parts` / `permute_surfaces`: "never", "test" (only when evaluating) or "train_test"
  (also as augmentation in training). A permutation relabels ids; the graph itself is unchanged.

Beyond the paper, `part_pe` may encode the part ids differently from the surface ids (null: as
`pe`). `part_pe: none` tests whether the part ids' codes limit transfer across sizes (trained on
A5, a network never sees the codes of ids 5 and 6 that every A7 graph carries), while the surface
ids (which side of a part a surface is) stay informative at any size. Measured, they do not: without
them the network plans larger assemblies no better, and A12 worse (docs/size-generalisation.md,
"Part ids the network never saw").

`part_id_range` R (None: the paper's ids 0..N−1) draws a part's id instead as a sorted random sample
of N ids from 0..R−1, in training and in evaluation (there seeded per assembly, so planning stays
deterministic): the randomised positional encoding of Ruoss et al. (ACL 2023) for length
generalisation. The ids keep their order (nearest the origin first) while a network trained on A3–A7
has seen the codes of every id below R, so an A12 carries no code it never saw. Measured, this does
not plan larger assemblies better either (docs/size-generalisation.md, "Ids drawn from a wider
range").

Also beyond the paper, `cell` (the run's `simulator.cell`; None: the paper's graph) gives every
part node what the cell decides beside the assembly: its clamp, its pose on the table and its
distance from the arms (grace/graphs/cell_features.py), an oracle input that measures how much
of the labels the graph cannot see (docs/information-ceiling.md).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from grace.domain.assembly import MIN_PARTS
from grace.errors import UserError


class PE(StrEnum):
    """How node ids become features (`model.graph.pe`, `model.graph.part_pe`)."""

    sinusoidal = "sinusoidal"
    random = "random"
    none = "none"


class Permute(StrEnum):
    """When node ids are relabelled at random (`model.graph.permute_parts` / `_surfaces`)."""

    never = "never"
    test = "test"
    train_test = "train_test"

    def applies(self, training: bool) -> bool:
        """Whether ids are permuted when encoding for training (True) or evaluation (False)."""
        return self is Permute.train_test or (self is Permute.test and not training)


def sinusoidal_pe(ids: np.ndarray, dim: int) -> np.ndarray:
    """Vaswani et al. encoding: PE[p, 2i] = sin(p / 10000^(2i/d)), PE[p, 2i+1] = cos(same)."""
    ids = np.asarray(ids, dtype=np.int64)
    if ids.size and ids.min() >= 0 and ids.max() < _PE_TABLE_ROWS:
        return _pe_table(dim)[ids]
    return _sinusoidal(ids, dim)


_PE_TABLE_ROWS = 64
"""Ids below this are looked up in a table computed once per dimension (inference latency)."""


def _sinusoidal(ids: np.ndarray, dim: int) -> np.ndarray:
    pos = np.asarray(ids, dtype=np.float64)[:, None]
    freq = np.power(10000.0, -np.arange(0, dim, 2, dtype=np.float64) / dim)
    pe = np.zeros((len(pos), dim))
    pe[:, 0::2] = np.sin(pos * freq)
    pe[:, 1::2] = np.cos(pos * freq[: dim // 2])
    return pe


@functools.cache
def _pe_table(dim: int) -> np.ndarray:
    table = _sinusoidal(np.arange(_PE_TABLE_ROWS), dim)
    table.flags.writeable = False
    return table


@dataclass(frozen=True)
class GraphEncoding:
    """How an Assembly Graph turns ids and relations into network inputs.

    `distance_scale` divides the parallel-surface distances (mm) so that they land in the range
    of the other edge codes (1, −1, 0) instead of dominating attention; 1.0 feeds raw mm as the
    reference does. The codes for same-part (1), orthogonal (−1) and self loop (0) are not scaled.
    """

    pe: PE = PE.sinusoidal
    pe_dim: int = 16
    permute_parts: Permute = Permute.never
    permute_surfaces: Permute = Permute.never
    distance_scale: float = 100.0
    part_pe: PE | None = None
    part_id_range: int | None = None
    cell: Any = field(default=None, hash=False)  # a CellConfig (or its mapping), or None

    def __post_init__(self) -> None:
        # Plain strings (a config without its schema, or a call from code) become the enums.
        for key, kind in (("pe", PE), ("permute_parts", Permute), ("permute_surfaces", Permute)):
            object.__setattr__(self, key, kind(getattr(self, key)))
        if self.part_pe is not None:
            object.__setattr__(self, "part_pe", PE(self.part_pe))
        if self.cell is not None:
            from grace.simulation.cell_config import CellConfig, typed

            object.__setattr__(self, "cell", typed(CellConfig, self.cell, "model.graph.cell"))
        if self.part_id_range is not None and self.part_id_range < MIN_PARTS:
            raise UserError(
                f"model.graph.part_id_range={self.part_id_range}: use null (ids 0..N-1) or at "
                "least the largest assembly's part count"
            )
        if self.distance_scale <= 0:
            raise UserError(
                f"model.graph.distance_scale={self.distance_scale}: use a positive scale "
                "(mm per unit)"
            )

    @property
    def extra_part_features(self) -> int:
        """Part-node features beyond the paper's (`cell`: CELL_FEATURES, else 0)."""
        if self.cell is None:
            return 0
        from grace.graphs.cell_features import CELL_FEATURES

        return CELL_FEATURES

    @property
    def randomised(self) -> bool:
        """True when encoding an assembly twice can give different inputs (needs an rng)."""
        return (
            PE.random in (self.pe, self.part_pe)
            or self.part_id_range is not None
            or self.permute_parts is not Permute.never
            or self.permute_surfaces is not Permute.never
        )

    def encode(
        self, ids: np.ndarray, rng: np.random.Generator | None, kind: PE | None = None
    ) -> np.ndarray:
        """Encode integer ids as `pe_dim` features according to `kind` (default `pe`)."""
        return _ENCODERS[kind or self.pe](np.asarray(ids), self.pe_dim, rng)


def _random_pe(ids: np.ndarray, dim: int, rng: np.random.Generator | None) -> np.ndarray:
    return _require(rng).standard_normal((len(ids), dim))


_ENCODERS: dict[PE, Callable[[np.ndarray, int, np.random.Generator | None], np.ndarray]] = {
    PE.sinusoidal: lambda ids, dim, rng: sinusoidal_pe(ids, dim),
    PE.random: _random_pe,
    PE.none: lambda ids, dim, rng: np.zeros((len(ids), dim)),
}


def node_ids(
    part_of_surface: np.ndarray,
    surface_index: np.ndarray,
    n_parts: int,
    enc: GraphEncoding,
    training: bool,
    rng: np.random.Generator | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Part ids (0..N−1, or sorted draws below `enc.part_id_range`) and surface ids (1..k on each
    part), permuted as `enc` asks."""
    part_ids = np.arange(n_parts)
    surface_ids = np.asarray(surface_index).copy()
    if enc.part_id_range is not None:
        if n_parts > enc.part_id_range:
            raise UserError(
                f"model.graph.part_id_range={enc.part_id_range}: an assembly has {n_parts} parts; "
                f"set it to at least {n_parts}"
            )
        part_ids = np.sort(_require(rng).choice(enc.part_id_range, n_parts, replace=False))
    if enc.permute_parts.applies(training):
        part_ids = part_ids[_require(rng).permutation(n_parts)]
    if enc.permute_surfaces.applies(training):
        for p in range(n_parts):
            own = np.flatnonzero(part_of_surface == p)
            surface_ids[own] = surface_ids[own][_require(rng).permutation(len(own))]
    return part_ids, surface_ids


def _require(rng: np.random.Generator | None) -> np.random.Generator:
    if rng is None:
        raise ValueError("this graph encoding is randomised: pass a seeded numpy Generator")
    return rng
