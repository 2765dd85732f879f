"""The two exact implementations of the GRACE network, chosen by `model.impl` (an object).

Both run the same parameters (grace_pyg.GraceNet) and agree to 1e-5; they differ in what a batch
holds and how the forward pass walks it:
- :class:`FastImpl` (`model/impl=fast`, default): padded per-assembly tensors, one surface
  embedding shared by all states of an assembly, dense attention (grace_fast.py);
- :class:`PygImpl` (`model/impl=pyg`): one PyG heterogeneous graph per state, the reference.

An implementation gives the training batches (`collate`, handed to the DataModule), the logits of
a training batch (`logits`) and the logits of many states of one assembly for planning
(`assembly_logits`, on a :class:`PreparedAssembly` that caches the per-assembly work).
"""

from __future__ import annotations

import numpy as np
import torch
from lightning.fabric.utilities.apply_func import move_data_to_device
from torch_geometric.data import Batch

from grace.domain.assembly import Assembly
from grace.graphs.assembly_graph import AssemblyTensors, state_flags, state_graph
from grace.graphs.datamodule import StateBatch, collate_dense, collate_graphs
from grace.graphs.dense import DenseAssemblies
from grace.model.grace_fast import SharedWork, fast_logits, shared_work, state_features
from grace.model.grace_pyg import GraceNet


class PreparedAssembly:
    """One assembly's encoded tensors on the network's `device` and, once needed, the work all
    its states share."""

    def __init__(
        self, assembly: Assembly, tensors: AssemblyTensors, device: torch.device | str = "cpu"
    ) -> None:
        self.assembly = assembly
        self.tensors = tensors
        self.device = torch.device(device)
        self.dense = move_data_to_device(DenseAssemblies.stack([tensors]), self.device)
        self._shared: SharedWork | None = None

    def shared(self, net: GraceNet) -> SharedWork:
        if self._shared is None:
            self._shared = shared_work(net, self.dense)
        return self._shared

    def part_features(self, net: GraceNet, states: np.ndarray) -> torch.Tensor:
        """Part features before the head (len(states), n_parts, hidden), on the fast path."""
        flags = state_flags(states, self.assembly.n_parts).to(self.device)
        index = torch.zeros(len(flags), dtype=torch.long, device=self.device)
        return state_features(net, self.dense, index, flags, self.shared(net))


class FastImpl:
    """Shared surface embedding per assembly and dense attention (the default)."""

    name = "fast"

    collate = staticmethod(collate_dense)

    def logits(self, net: GraceNet, batch: StateBatch) -> torch.Tensor:
        return fast_logits(net, batch.inputs, batch.state_assembly, batch.flags)

    def assembly_logits(
        self, net: GraceNet, prepared: PreparedAssembly, states: np.ndarray
    ) -> torch.Tensor:
        return net.readout(prepared.part_features(net, states))


class PygImpl:
    """One PyG graph per state through the message-passing layers (the reference path)."""

    name = "pyg"

    collate = staticmethod(collate_graphs)

    def logits(self, net: GraceNet, batch: StateBatch) -> torch.Tensor:
        flat = net(batch.inputs)
        out = flat.new_zeros(batch.mask.shape + flat.shape[1:])
        out[batch.mask] = flat
        return out

    def assembly_logits(
        self, net: GraceNet, prepared: PreparedAssembly, states: np.ndarray
    ) -> torch.Tensor:
        batch = Batch.from_data_list([state_graph(prepared.tensors, int(s)) for s in states])
        flat = net(batch.to(prepared.device))
        return flat.view(len(states), prepared.assembly.n_parts, *flat.shape[1:])


NetImpl = FastImpl | PygImpl
