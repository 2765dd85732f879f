"""Training batches of states as each implementation of the network consumes them.

A batch holds T states of A assemblies (:class:`StateBatch`); a collate function builds its
network inputs: padded per-assembly tensors for the fast path (:func:`collate_dense`) or one PyG
graph per state for the reference path (:func:`collate_graphs`). Apart from the DataModule
(grace/graphs/datamodule.py), so that the network's implementations (grace/model/impls.py) and
planning with them load neither Lightning nor PyG.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from grace.graphs.assembly_graph import AssemblyTensors, state_flags, state_graph
from grace.graphs.dense import DenseAssemblies


@dataclass
class StateBatch:
    """T states of A assemblies; `inputs` is a PyG Batch or DenseAssemblies, per path."""

    inputs: object
    state_assembly: torch.Tensor  # (T,) index into the batch's assemblies
    flags: torch.Tensor  # (T, N) assembled flags, 0 on padding
    labels: torch.Tensor  # (T, N) next-step targets in [0, 1] (1 = valid), 0 on padding
    mask: torch.Tensor  # (T, N) bool: real part nodes
    weights: torch.Tensor | None = None  # (T,) per-state loss weights; None = all 1
    placeable: torch.Tensor | None = None  # (T, N) 1 where placing the part is feasible

    @property
    def n_states(self) -> int:
        return self.flags.shape[0]


Collate = Callable[
    [Sequence[AssemblyTensors], Sequence[np.ndarray], Sequence[np.ndarray]], StateBatch
]
"""(per-assembly tensors, their state bitmasks, their label bitmasks) → one batch."""


def state_batch(
    inputs: object,
    tensors: Sequence[AssemblyTensors],
    states: Sequence[np.ndarray],
    labels: Sequence[np.ndarray],
) -> StateBatch:
    """The batch of `states` (with their `labels`) of the assemblies `tensors`, whose network
    inputs a collate function built as `inputs`."""
    n = max(t.n_parts for t in tensors)
    state_assembly = torch.cat(
        [torch.full((len(s),), i, dtype=torch.long) for i, s in enumerate(states)]
    )
    sizes = torch.tensor([t.n_parts for t in tensors])[state_assembly]
    mask = torch.arange(n).unsqueeze(0) < sizes.unsqueeze(1)
    flags = state_flags(np.concatenate(states), n) * mask
    y = state_flags(np.concatenate(labels), n) * mask
    return StateBatch(inputs, state_assembly, flags, y, mask)


def collate_dense(
    tensors: Sequence[AssemblyTensors],
    states: Sequence[np.ndarray],
    labels: Sequence[np.ndarray],
) -> StateBatch:
    """One batch whose inputs are the assemblies' padded tensors (the fast path)."""
    return state_batch(DenseAssemblies.stack(list(tensors)), tensors, states, labels)


def collate_graphs(
    tensors: Sequence[AssemblyTensors],
    states: Sequence[np.ndarray],
    labels: Sequence[np.ndarray],
) -> StateBatch:
    """One batch whose inputs are the per-state PyG graphs (the reference path)."""
    from torch_geometric.data import Batch  # the reference path only: planning never loads PyG

    pairs = zip(tensors, states, strict=True)
    graphs = [state_graph(t, int(s)) for t, group in pairs for s in group]
    return state_batch(Batch.from_data_list(graphs), tensors, states, labels)
