"""GRACE (SPEC §5) on PyTorch Geometric: the reference per-state path and the shared weights.

Block = GATv2 attention conv → InstanceNorm (affine, no running stats) → tanh.
Surface blocks: GATv2 on the complete surface graph (edge_dim 1, self loops filled with 0).
Part block: GATv2 surface→part without self loops, in a HeteroConv with mean aggregation.
Head: one linear layer per part node; `forward` returns logits, sigmoid gives the scores.
The fast path (grace_fast.py) reuses exactly these modules' parameters.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import torch
from torch import nn
from torch_geometric.data import Batch, HeteroData
from torch_geometric.nn import GATv2Conv, HeteroConv, InstanceNorm

from grace.graphs.assembly_graph import PART_EDGE, SURFACE_EDGE


@dataclass(frozen=True)
class NetConfig:
    """Network shape; the defaults are the paper's (51,701 trainable parameters).

    `state_surfaces` (not in the paper, off by default) prefixes every surface's input with its
    part's assembled flag. In the paper's network the state reaches a part only through its own
    flag and the part-level InstanceNorm statistics, so "is my neighbour placed" is hard to read;
    this variant lets the surface blocks see the state, at the price of the shared embedding.
    """

    hidden: int = 94
    surface_blocks: int = 3
    negative_slope: float = 0.15
    pe_dim: int = 16
    state_surfaces: bool = False

    @property
    def part_in(self) -> int:
        return 2 + self.pe_dim

    @property
    def surface_in(self) -> int:
        return 1 + self.pe_dim + int(self.state_surfaces)


class GraceNet(nn.Module):
    """The GRACE network; `forward` is the plain PyG per-state path."""

    def __init__(self, cfg: NetConfig) -> None:
        super().__init__()
        self.cfg = cfg
        h = cfg.hidden
        self.surface_convs = nn.ModuleList(
            HeteroConv(
                {
                    SURFACE_EDGE: GATv2Conv(
                        cfg.surface_in if i == 0 else h,
                        h,
                        negative_slope=cfg.negative_slope,
                        edge_dim=1,
                        add_self_loops=True,
                        fill_value=0.0,
                    )
                },
                aggr="mean",
            )
            for i in range(cfg.surface_blocks)
        )
        self.surface_norms = nn.ModuleList(
            InstanceNorm(h, affine=True, track_running_stats=False)
            for _ in range(cfg.surface_blocks)
        )
        with warnings.catch_warnings():
            # Surfaces are no destination of the part conv by design: they are read, not updated.
            warnings.filterwarnings("ignore", message="There exist node types")
            self.part_conv = HeteroConv(
                {
                    PART_EDGE: GATv2Conv(
                        (h, cfg.part_in), h, negative_slope=cfg.negative_slope, add_self_loops=False
                    )
                },
                aggr="mean",
            )
        self.part_norm = InstanceNorm(h, affine=True, track_running_stats=False)
        self.head = nn.Linear(h, 1)

    def surface_gat(self, i: int) -> GATv2Conv:
        return self.surface_convs[i].convs[SURFACE_EDGE]

    @property
    def part_gat(self) -> GATv2Conv:
        return self.part_conv.convs[PART_EDGE]

    def forward(self, data: HeteroData | Batch) -> torch.Tensor:
        """Logits of all part nodes of a (batched) Assembly Graph, shape (n_part_nodes,)."""
        surf_batch = _batch_vector(data, "surface")
        part_batch = _batch_vector(data, "part")
        x_surface = data["surface"].x
        if self.cfg.state_surfaces:
            src, owner = data[PART_EDGE].edge_index
            flag = torch.zeros_like(x_surface[:, 0])
            flag[src] = data["part"].x[owner, 0]
            x_surface = torch.cat([flag.unsqueeze(-1), x_surface], dim=1)
        edges = {SURFACE_EDGE: data[SURFACE_EDGE].edge_index}
        attrs = {SURFACE_EDGE: data[SURFACE_EDGE].edge_attr}
        for conv, norm in zip(self.surface_convs, self.surface_norms, strict=True):
            out = conv({"surface": x_surface}, edges, edge_attr_dict=attrs)["surface"]
            x_surface = torch.tanh(norm(out, surf_batch))
        x = {"surface": x_surface, "part": data["part"].x}
        out = self.part_conv(x, {PART_EDGE: data[PART_EDGE].edge_index})["part"]
        x_part = torch.tanh(self.part_norm(out, part_batch))
        return self.head(x_part).squeeze(-1)


def _batch_vector(data: HeteroData | Batch, node_type: str) -> torch.Tensor:
    store = data[node_type]
    if "batch" in store:
        return store.batch
    return torch.zeros(store.num_nodes, dtype=torch.long, device=store.x.device)


def count_parameters(net: nn.Module) -> int:
    """Number of trainable parameters (SPEC §5: 51.7 K at the paper's configuration)."""
    return sum(p.numel() for p in net.parameters() if p.requires_grad)
