"""The scale of the network's size-dependent terms, measured per assembly size with forward hooks
(docs/size-generalisation.md).

Terms whose magnitude grows with the number of parts push a network trained on small assemblies
into inputs it never saw. Measured on the reference path (grace_pyg.GraceNet.forward, which runs
every block as a module and has the same weights and outputs as the fast path, to 1e-5), per
state:
- `surface_norm_<i>` / `part_norm`: the standard deviation over a state's surfaces / parts of the
  InstanceNorm's input (mean over channels), the statistic the norm divides by;
- `placed_sum` / `unplaced_sum`: the relational readout's pools of pair features over the other
  placed / unplaced parts (the fuse layer's input: sums, or means or maxima by `model.net.pool`),
  root mean square per part;
- `part_pe_term` / `surface_pe_term`: what the positional encodings add to the first layers'
  pre-activations (the PE columns of the part block's and of the first surface block's input
  weights times the encodings), root mean square per node;
- `head_input`: the part features the head reads, root mean square per part.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence

import numpy as np
import torch
from torch import nn
from torch_geometric.data import Batch
from torch_geometric.utils import scatter

from grace.domain.sample import LabelledAssembly
from grace.evaluation.step_states import onpath_states
from grace.model.checkpoints import KeptModel
from grace.model.grace_pyg import GraceNet
from grace.model.impls import PygImpl
from grace.model.module import GraceModule
from grace.model.scoring import make_scorer

PART_PE_COLUMNS = slice(2, None)
"""Part node features are [assembled flag, part type, PE] (grace/graphs/assembly_graph.py)."""
SURFACE_PE_COLUMNS = slice(1, None)
"""Surface node features are [surface type, PE]."""


def _rms(x: torch.Tensor) -> torch.Tensor:
    """Root mean square of each row."""
    return x.square().mean(dim=-1).sqrt()


def _spread(x: torch.Tensor, batch: torch.Tensor | None) -> torch.Tensor:
    """Per graph of `batch`: the standard deviation over its nodes, mean over channels."""
    batch = torch.zeros(len(x), dtype=torch.long) if batch is None else batch
    mean = scatter(x, batch, dim=0, reduce="mean")
    var = scatter((x - mean[batch]).square(), batch, dim=0, reduce="mean")
    return var.sqrt().mean(dim=-1)


class ActivationProbe:
    """Forward hooks on a GraceNet that collect the terms of the module docstring; a context
    manager, so the hooks never outlive the measurement."""

    def __init__(self, net: GraceNet) -> None:
        self.net = net
        self.values: dict[str, list[np.ndarray]] = defaultdict(list)
        self._handles: list = []

    def _keep(self, term: str, value: torch.Tensor) -> None:
        self.values[term].append(value.detach().numpy().astype(np.float64))

    def _norm_hook(self, term: str):
        def hook(_: nn.Module, args: tuple) -> None:
            self._keep(term, _spread(args[0], args[1] if len(args) > 1 else None))

        return hook

    def _inputs(self, _: nn.Module, args: tuple) -> None:
        data: Batch = args[0]
        part_w = self.net.part_gat.lin_r.weight[:, PART_PE_COLUMNS]
        surface_w = self.net.surface_gat(0).lin_l.weight[:, SURFACE_PE_COLUMNS]
        self._keep("part_pe_term", _rms(data["part"].x[:, PART_PE_COLUMNS] @ part_w.T))
        self._keep("surface_pe_term", _rms(data["surface"].x[:, SURFACE_PE_COLUMNS] @ surface_w.T))

    def _fuse(self, _: nn.Module, args: tuple) -> None:
        h, p = self.net.cfg.hidden, self.net.cfg.pair_readout
        self._keep("placed_sum", _rms(args[0][:, h : h + p]))
        self._keep("unplaced_sum", _rms(args[0][:, h + p : h + 2 * p]))

    def __enter__(self) -> ActivationProbe:
        net, add = self.net, self._handles.append
        add(net.register_forward_pre_hook(self._inputs))
        for i, norm in enumerate(net.surface_norms):
            add(norm.register_forward_pre_hook(self._norm_hook(f"surface_norm_{i}")))
        add(net.part_norm.register_forward_pre_hook(self._norm_hook("part_norm")))
        if net.cfg.pair_readout:
            add(net.fuse.register_forward_pre_hook(self._fuse))
        add(net.head.register_forward_pre_hook(lambda _, a: self._keep("head_input", _rms(a[0]))))
        return self

    def __exit__(self, *_: object) -> None:
        for handle in self._handles:
            handle.remove()
        self._handles.clear()

    def summary(self) -> dict[str, dict[str, float]]:
        """Mean and std of each term over everything collected."""
        out = {}
        for term, parts in sorted(self.values.items()):
            v = np.concatenate(parts)
            out[term] = {"mean": float(v.mean()), "std": float(v.std()), "count": int(v.size)}
        return out


def activation_scale(
    module: GraceModule | KeptModel,
    samples: Sequence[LabelledAssembly],
    states_per_assembly: int,
    seed: int = 0,
) -> dict[str, dict[str, float]]:
    """The terms of the module docstring over up to `states_per_assembly` states on the true
    orders of each of `samples` (a seeded choice), on the reference path (a loaded `module`'s
    network must be built on PyG's layers: grace/model/checkpoints.py)."""
    rng = np.random.default_rng(seed)
    scorer = make_scorer(module, PygImpl())
    with ActivationProbe(module.net) as probe:
        for sample in samples:
            states, _ = onpath_states(sample.truth)
            if len(states) > states_per_assembly:
                states = np.sort(rng.choice(states, states_per_assembly, replace=False))
            scorer(sample.assembly, states)
    return probe.summary()
