"""Next-step scores for planning: all states of an assembly share one surface embedding.

`make_scorer(module)(assembly, states)` returns the (len(states), n_parts) next-step scores of the
policy (paper Sec. IV-C) for many states at once; the per-assembly work (surface blocks and both
part-block variants, see grace_fast.py) is cached, so scoring the 2^N − 1 distinct states of
Algorithm 1 costs one surface pass plus a small per-state step. Randomised test-time encodings
(the paper's ablation, Table 4) are seeded by the module's seed and the assembly's content, so
repeated calls agree.
"""

from __future__ import annotations

import zlib
from collections import OrderedDict
from typing import TYPE_CHECKING

import numpy as np
import torch

from grace.domain.assembly import Assembly
from grace.graphs.assembly_graph import AssemblyTensors, encode_assembly
from grace.model.impls import FastImpl, NetImpl, PreparedAssembly

if TYPE_CHECKING:  # scoring reads the same of both; importing them would load Lightning
    from grace.model.checkpoints import KeptModel
    from grace.model.module import GraceModule

    Model = GraceModule | KeptModel


def _fingerprint(assembly: Assembly) -> int:
    data = repr([(p.name, str(p.type)) for p in assembly.parts]).encode()
    data += b"".join(np.ascontiguousarray(p.pose).tobytes() for p in assembly.parts)
    return zlib.crc32(np.ascontiguousarray(assembly.relations).tobytes(), zlib.crc32(data))


def evaluation_tensors(module: Model, assembly: Assembly) -> AssemblyTensors:
    """The evaluation-time encoding of `assembly` (deterministic also for randomised variants)."""
    rng = None
    if module.enc.randomised:
        rng = np.random.default_rng([module.seed, _fingerprint(assembly)])
    return encode_assembly(assembly, module.enc, training=False, rng=rng)


class Scorer:
    """Callable `scorer(assembly, states) -> scores` with a small per-assembly cache."""

    def __init__(self, module: Model, impl: NetImpl | None = None, cache_size: int = 64):
        self.module = module.eval()
        self.impl = impl or module.impl
        self.cache_size = cache_size
        # Keyed by id(); the entry keeps the assembly alive, so the id cannot be reused meanwhile.
        self._cache: OrderedDict[int, PreparedAssembly] = OrderedDict()

    def clear(self) -> None:
        """Forget every cached assembly (the next call on any assembly starts cold)."""
        self._cache.clear()

    def _prepared(self, assembly: Assembly) -> PreparedAssembly:
        hit = self._cache.get(id(assembly))
        if hit is not None and hit.assembly is assembly:
            self._cache.move_to_end(id(assembly))
            return hit
        tensors = evaluation_tensors(self.module, assembly).to(self.module.dtype)
        prepared = PreparedAssembly(assembly, tensors, self.module.device)
        self._cache[id(assembly)] = prepared
        if len(self._cache) > self.cache_size:
            self._cache.popitem(last=False)
        return prepared

    @torch.inference_mode()
    def part_features(self, assembly: Assembly, states: np.ndarray) -> torch.Tensor:
        """Part features before the head (fast path), (len(states), n_parts, hidden)."""
        return self._prepared(assembly).part_features(self.module.net, states)

    @torch.inference_mode()
    def __call__(self, assembly: Assembly, states: np.ndarray) -> np.ndarray:
        states = np.asarray(states, dtype=np.int64).reshape(-1)
        scores = self.impl.assembly_scores(self.module.net, self._prepared(assembly), states)
        return scores.cpu().numpy().astype(np.float64)


def make_scorer(module: Model, impl: NetImpl | None = None) -> Scorer:
    """Scorer over `module` on its own implementation, or on `impl` if given."""
    return Scorer(module, impl)


def part_embeddings(module: Model, assembly: Assembly, state: int = 0) -> np.ndarray:
    """Part node features (n_parts, hidden) after the part block, for mean-pooled classifiers."""
    feats = Scorer(module, FastImpl(), 1).part_features(assembly, np.array([state]))
    return feats[0].cpu().numpy().astype(np.float64)
