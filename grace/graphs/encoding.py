"""Node identities of the Assembly Graph and their positional encodings (SPEC §4, §9 ablation).

Part ids are the canonical part indices (SPEC §2: numbered from the part closest to the origin);
surface ids are the surface's 1-based index on its own part (clockwise from the part's top), so the
id says which side of a part a surface is. Both are encoded with a 16-d sinusoidal encoding.

The ablation variants of SPEC §9 are options here, not code forks:
- `pe`: "sinusoidal" (paper), "random" (fresh N(0,1) values per graph instead of the encoding) or
  "none" (zeros, so the network keeps its shape and parameter count);
- `permute_parts` / `permute_surfaces`: "never", "test" (only when evaluating) or "train_test"
  (also as augmentation in training). A permutation relabels ids; the graph itself is unchanged.

Beyond the paper, `part_pe` may encode the part ids differently from the surface ids (null: as
`pe`). `part_pe: none` is the one-to-many lead of issue 4: trained on A5, a network never sees the
encodings of part ids 5 and 6 that every A7 graph carries, while the surface ids (which side of a
part a surface is) stay informative at any size.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

PE_KINDS = ("sinusoidal", "random", "none")
PERMUTE_MODES = ("never", "test", "train_test")


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

    pe: str = "sinusoidal"
    pe_dim: int = 16
    permute_parts: str = "never"
    permute_surfaces: str = "never"
    distance_scale: float = 100.0
    part_pe: str | None = None

    def __post_init__(self) -> None:
        for key in ("pe", "part_pe"):
            value = getattr(self, key)
            if value not in PE_KINDS and not (key == "part_pe" and value is None):
                raise ValueError(f"model.graph.{key}={value!r}: use one of {PE_KINDS}")
        for key in ("permute_parts", "permute_surfaces"):
            if getattr(self, key) not in PERMUTE_MODES:
                raise ValueError(f"model.graph.{key}={getattr(self, key)!r}: use {PERMUTE_MODES}")
        if self.distance_scale <= 0:
            raise ValueError("model.graph.distance_scale must be > 0 (mm per unit)")

    @property
    def randomised(self) -> bool:
        """True when encoding an assembly twice can give different inputs (needs an rng)."""
        return (
            "random" in (self.pe, self.part_pe)
            or self.permute_parts != "never"
            or self.permute_surfaces != "never"
        )

    def permutes(self, mode: str, training: bool) -> bool:
        return mode == "train_test" or (mode == "test" and not training)

    def encode(
        self, ids: np.ndarray, rng: np.random.Generator | None, kind: str | None = None
    ) -> np.ndarray:
        """Encode integer ids as `pe_dim` features according to `kind` (default `pe`)."""
        kind = kind or self.pe
        if kind == "sinusoidal":
            return sinusoidal_pe(ids, self.pe_dim)
        if kind == "none":
            return np.zeros((len(ids), self.pe_dim))
        return _require(rng).standard_normal((len(ids), self.pe_dim))


def node_ids(
    part_of_surface: np.ndarray,
    surface_index: np.ndarray,
    n_parts: int,
    enc: GraphEncoding,
    training: bool,
    rng: np.random.Generator | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Part ids (0..N−1) and surface ids (1..k on each part), permuted as `enc` asks."""
    part_ids = np.arange(n_parts)
    surface_ids = np.asarray(surface_index).copy()
    if enc.permutes(enc.permute_parts, training):
        part_ids = _require(rng).permutation(n_parts)
    if enc.permutes(enc.permute_surfaces, training):
        for p in range(n_parts):
            own = np.flatnonzero(part_of_surface == p)
            surface_ids[own] = surface_ids[own][_require(rng).permutation(len(own))]
    return part_ids, surface_ids


def _require(rng: np.random.Generator | None) -> np.random.Generator:
    if rng is None:
        raise ValueError("this graph encoding is randomised: pass a seeded numpy Generator")
    return rng
