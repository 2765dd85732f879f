"""The two exact implementations of the GRACE network, chosen by `model.impl` (an object).

Both run the same parameters (grace_pyg.GraceNet) and agree to 1e-5; they differ in what a batch
holds and how the forward pass walks it:
- :class:`FastImpl` (`model/impl=fast`, default): padded per-assembly tensors, one surface
  embedding shared by all states of an assembly, dense attention (grace_fast.py);
- :class:`PygImpl` (`model/impl=pyg`): one PyG heterogeneous graph per state, the reference;
- :class:`CompiledImpl` (`model/impl=compiled`): the fast path, its planning queries through
  torch.compile (training runs the fast path as it is).

An implementation gives the training batches (`collate`, handed to the DataModule), the logits of
a training batch (`logits`) and the next-step scores of many states of one assembly for planning
(`assembly_scores`, on a :class:`PreparedAssembly` that caches the per-assembly work).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import torch

from grace.domain.assembly import Assembly
from grace.graphs.assembly_graph import AssemblyTensors, state_graph
from grace.graphs.batches import StateBatch, collate_dense, collate_graphs
from grace.graphs.dense import DenseAssemblies
from grace.model.grace_fast import (
    WEIGHT_LAYERS,
    SharedWork,
    fast_logits,
    first_planning_scores,
    one_assembly_states,
    planning_scores,
    shared_work,
    state_features,
)
from grace.model.grace_pyg import GraceNet, Layers, pyg_layers


class PlanningSteps(NamedTuple):
    """The fast path's two calls for planning, each from state bitmasks to scores: a first
    query of an assembly (the work its states share, and the queried states' scores), then the
    scores of further states from that work."""

    first: Callable[..., tuple[SharedWork, torch.Tensor]]
    scores: Callable[..., torch.Tensor]


FAST_STEPS = PlanningSteps(first_planning_scores, planning_scores)


class PreparedAssembly:
    """One assembly's encoded tensors on the network's `device` and, once needed, the work all
    its states share."""

    def __init__(
        self, assembly: Assembly, tensors: AssemblyTensors, device: torch.device | str = "cpu"
    ) -> None:
        self.assembly = assembly
        self.tensors = tensors
        self.device = torch.device(device)
        self.dense = DenseAssemblies.stack([tensors])
        if self.dense.surface_x.device != self.device:  # the walk costs a cold query 30 µs
            # Imported here: Lightning takes seconds to load, and planning on CPU never moves.
            from lightning.fabric.utilities.apply_func import move_data_to_device

            self.dense = move_data_to_device(self.dense, self.device)
        self._shared: SharedWork | None = None

    def shared(self, net: GraceNet) -> SharedWork:
        """The work its states share."""
        if self._shared is None:
            self._shared = shared_work(net, self.dense)
        return self._shared

    def part_features(self, net: GraceNet, states: np.ndarray) -> torch.Tensor:
        """Part features before the head (len(states), n_parts, hidden), on the fast path."""
        inputs = one_assembly_states(self.dense, states)
        return state_features(net, self.dense, *inputs, self.shared(net))

    def scores(
        self, net: GraceNet, states: np.ndarray, steps: PlanningSteps = FAST_STEPS
    ) -> torch.Tensor:
        """Next-step scores of `states` on the fast path (`steps`: its calls, or compiled
        copies)."""
        bitmasks = torch.as_tensor(states, dtype=torch.int64, device=self.device)
        if self._shared is None:
            self._shared, scores = steps.first(net, self.dense, bitmasks)
            return scores
        return steps.scores(net, self.dense, bitmasks, self._shared)


class FastImpl:
    """Shared surface embedding per assembly and dense attention (the default)."""

    name = "fast"

    collate = staticmethod(collate_dense)

    @staticmethod
    def loaded_layers() -> Layers:
        """The layers of a network loaded to run on this path: holders of its parameters, which
        are all the fast path reads (grace_fast.WEIGHT_LAYERS, no PyG)."""
        return WEIGHT_LAYERS

    def logits(self, net: GraceNet, batch: StateBatch) -> torch.Tensor:
        return fast_logits(net, batch.inputs, batch.state_assembly, batch.flags)

    def assembly_scores(
        self, net: GraceNet, prepared: PreparedAssembly, states: np.ndarray
    ) -> torch.Tensor:
        return prepared.scores(net, states)


class PygImpl:
    """One PyG graph per state through the message-passing layers (the reference path)."""

    name = "pyg"

    collate = staticmethod(collate_graphs)

    loaded_layers = staticmethod(pyg_layers)  # a loaded network runs PyG's modules here

    def logits(self, net: GraceNet, batch: StateBatch) -> torch.Tensor:
        flat = net(batch.inputs)
        out = flat.new_zeros(batch.mask.shape + flat.shape[1:])
        out[batch.mask] = flat
        return out

    def assembly_scores(
        self, net: GraceNet, prepared: PreparedAssembly, states: np.ndarray
    ) -> torch.Tensor:
        from torch_geometric.data import Batch  # the reference path only: planning never loads PyG

        batch = Batch.from_data_list([state_graph(prepared.tensors, int(s)) for s in states])
        flat = net(batch.to(prepared.device))
        return net.scores(flat.view(len(states), prepared.assembly.n_parts, *flat.shape[1:]))


class CompiledImpl(FastImpl):
    """The fast path with its planning queries compiled by torch.compile (inductor).

    A query of one state is a few hundred small tensor operations, each costing more in
    dispatch than in arithmetic (docs/training.md, "Inference"); compiled, they run as a few
    fused C++ loops. Shapes are dynamic, so a new assembly reuses the compiled code; compiling
    costs 10-45 s the first time a process scores one state and again the first time it scores
    many: it pays for a planning session, not for one query. Training runs the
    fast path as it is (`logits` is FastImpl's).
    """

    name = "compiled"

    def __init__(self, backend: str = "inductor") -> None:
        self.backend = backend

    @functools.cached_property
    def _compiled(self) -> PlanningSteps:
        """The planning calls compiled, on first use (compiling happens at the first call of
        each)."""
        return PlanningSteps(
            *(torch.compile(f, dynamic=True, backend=self.backend) for f in FAST_STEPS)
        )

    def __getstate__(self) -> dict:
        """Pickled (a checkpoint's hyper-parameters) without the compiled code."""
        return {"backend": self.backend}

    def assembly_scores(
        self, net: GraceNet, prepared: PreparedAssembly, states: np.ndarray
    ) -> torch.Tensor:
        return prepared.scores(net, states, self._compiled)


NetImpl = FastImpl | PygImpl | CompiledImpl
