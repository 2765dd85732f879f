"""GRACE on PyTorch Geometric: the reference per-state path and the shared weights.

The network of paper Sec. IV-C (docs/training.md).

Block = GATv2 attention conv → InstanceNorm (affine, no running stats) → tanh.
Surface blocks: GATv2 on the complete surface graph (edge_dim 1, self loops filled with 0).
Part block: GATv2 surface→part without self loops, in a HeteroConv with mean aggregation.
Head: one linear layer per part node; `forward` returns logits, sigmoid gives the scores.
The fast path (grace_fast.py) reuses exactly these modules' parameters; it reads nothing else of
them, so a network that is only loaded and run on it is built from plain holders of the same
parameters (grace_fast.WEIGHT_LAYERS) and never loads PyG, whose import takes seconds.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import TYPE_CHECKING, NamedTuple

import torch
import torch.nn.functional as F
from torch import nn

from grace.errors import UserError
from grace.graphs.assembly_graph import PAIR_EDGE, PART_EDGE, SURFACE_EDGE
from grace.graphs.pair_geometry import PAIR_GEOMETRY_FEATURES

if TYPE_CHECKING:
    from torch_geometric.data import Batch, HeteroData


class Score(StrEnum):
    """How the two outputs of `placeable_head` form the planner's score (`model.net.score`,
    docs/training.md): `product` y_step · y_place, `min` min(y_step, y_place), `geometric`
    sqrt(y_step · y_place), `next_step` y_step alone. With `product` and `min` either output
    vetoes a step: a part whose next-step output is below λ scores below λ whatever the physical
    output says, so a dead-end step learnt at its target (< λ) is never planned; the geometric
    mean lifts such a step above λ when the physical output is confident (0.4 → 0.63)."""

    product = "product"
    min = "min"
    geometric = "geometric"
    next_step = "next_step"


SCORE_RULES: dict[Score, Callable[[torch.Tensor], torch.Tensor]] = {
    Score.product: lambda log_p: torch.exp(log_p.sum(dim=-1)),
    Score.min: lambda log_p: torch.exp(log_p.min(dim=-1).values),
    Score.geometric: lambda log_p: torch.exp(log_p.mean(dim=-1)),
    Score.next_step: lambda log_p: torch.exp(log_p[..., 0]),
}
"""Each rule on the two outputs' log-sigmoids (..., 2) → scores (...)."""


class Pool(StrEnum):
    """How the pair readout pools pair features over a set of other parts (`model.net.pool`,
    docs/size-generalisation.md): `sum` (the first readout), `mean` or `max`. A sum grows with
    the number of parts, so a network trained on small assemblies reads values on a large one
    that it never saw; a mean or a max keeps its value when the same pair features repeat."""

    sum = "sum"
    mean = "mean"
    max = "max"


@dataclass(frozen=True)
class NetConfig:
    """Network shape; the defaults are the paper's (51,701 trainable parameters).

    `state_blocks` (not in the paper: 0 by default) lets the last k surface blocks see the state:
    the input of block `surface_blocks − k` gets each surface's part assembled flag as one more
    feature. In the paper's network the state reaches a part only through its own flag and the
    part-level InstanceNorm statistics, so "is my neighbour placed" is hard to read. The blocks
    before the first state-aware one stay shared by all states of an assembly (grace_fast.py).

    `pair_readout` (not in the paper: 0 by default) is the width of a relational readout that
    keeps the shared embedding: from the state-blind surface features it forms a feature vector
    per ordered pair of parts, the mean over their surface pairs of
    LeakyReLU(W_dst x_a + W_src x_b + w · relation_ab); a state then pools it (`pool`) over the
    other placed parts and over the other unplaced parts, and one layer fuses both pools into the
    part features before the head. So a part reads "which of my neighbours are placed, and which
    still wait" at the cost of a few small tensor operations per state. Each of
    `readout_rounds − 1` further rounds sends every part's fused features, projected to the pair
    width, through the same pair features to the other parts (two hops: "is the neighbour that I
    would block still waiting, and can it still be placed?").

    `pool` (:class:`Pool`) says how pair features are pooled over placed, over unplaced and (in
    further rounds) over all other parts. With `mean` or `max` the fuse layer also reads the
    share of the other parts that are placed, the one count a size-free pool loses.

    `pair_geometry` (not in the paper: 0 here, 64 in the default model `grace_geometric`) adds
    to each pair feature a small MLP (this hidden width) of the pair's relative geometry
    (grace.graphs.pair_geometry: one part's footprint in the other's frame), so "does m stand
    where n's fingers go" is read from the pair itself rather than pieced together from unsigned
    surface distances. Needs `pair_readout`.

    `placeable_head` (not in the paper: off here, on in `grace_geometric`) adds a second output
    per part, trained to say whether placing the part is physically feasible (the ground truth's
    `placeable`, dead ends included), beside the next-step output; `score` says how both form
    the policy's score (:class:`Score`, :meth:`GraceNet.scores`; ignored with one output). A
    wrong complete sequence needs a physically infeasible step that scores above λ, and the
    second output is trained on exactly that question in every reachable state. The score is not
    part of the loss: the same weights plan under every rule.
    """

    hidden: int = 94
    surface_blocks: int = 3
    negative_slope: float = 0.15
    pe_dim: int = 16
    state_blocks: int = 0
    pair_readout: int = 0
    readout_rounds: int = 1
    pair_geometry: int = 0
    pool: Pool = Pool.sum
    placeable_head: bool = False
    score: Score = Score.min
    extra_part_features: int = 0  # part-node inputs beyond the paper's (model.graph.cell)

    def __post_init__(self) -> None:
        object.__setattr__(self, "score", Score(self.score))  # a plain string becomes the enum
        object.__setattr__(self, "pool", Pool(self.pool))
        if not 0 <= self.state_blocks <= self.surface_blocks:
            raise UserError(
                f"model.net.state_blocks={self.state_blocks}: use 0 to model.net.surface_blocks="
                f"{self.surface_blocks}"
            )
        if self.readout_rounds < 1 or (self.readout_rounds > 1 and not self.pair_readout):
            raise UserError(
                f"model.net.readout_rounds={self.readout_rounds}: use 1, or more with "
                "model.net.pair_readout > 0"
            )
        if self.pair_geometry < 0 or (self.pair_geometry and not self.pair_readout):
            raise UserError(
                f"model.net.pair_geometry={self.pair_geometry}: use 0, or a width > 0 with "
                "model.net.pair_readout > 0"
            )

    @property
    def first_state_block(self) -> int:
        """Index of the first surface block that sees the state (= surface_blocks if none)."""
        return self.surface_blocks - self.state_blocks

    def block_in(self, i: int) -> int:
        """Input width of surface block i (+1 for the assembled flag at the first state block)."""
        width = self.surface_in if i == 0 else self.hidden
        return width + int(self.state_blocks > 0 and i == self.first_state_block)

    @property
    def static_width(self) -> int:
        """Width of the state-blind surface features that the pair readout reads."""
        return self.hidden if self.first_state_block > 0 else self.surface_in

    @property
    def fuse_in(self) -> int:
        """Input width of the readout's fuse layer: part features, the placed and unplaced
        pools, and with a size-free pool the placed share."""
        return self.hidden + 2 * self.pair_readout + int(self.pool != Pool.sum)

    @property
    def part_in(self) -> int:
        return 2 + self.pe_dim + self.extra_part_features

    @property
    def surface_in(self) -> int:
        return 1 + self.pe_dim


class Layers(NamedTuple):
    """The classes GraceNet builds its attention blocks from, called as PyG's: `gat` as
    GATv2Conv, `hetero` as HeteroConv, `norm` as InstanceNorm."""

    gat: Callable[..., nn.Module]
    hetero: Callable[..., nn.Module]
    norm: Callable[..., nn.Module]


def pyg_layers() -> Layers:
    """PyG's layers (imported on first use: PyG takes seconds to load)."""
    from torch_geometric.nn import GATv2Conv, HeteroConv, InstanceNorm

    return Layers(GATv2Conv, HeteroConv, InstanceNorm)


class GraceNet(nn.Module):
    """The GRACE network; `forward` is the plain PyG per-state path.

    Built from PyG's `layers` by default, initialised as PyG initialises them; with
    grace_fast.WEIGHT_LAYERS it holds the same parameters under the same names, uninitialised,
    for weights to be loaded and run on the fast path (`forward` needs PyG's layers).
    """

    def __init__(self, cfg: NetConfig, layers: Layers | None = None) -> None:
        super().__init__()
        self.cfg = cfg
        h = cfg.hidden
        layers = layers or pyg_layers()
        self.surface_convs = nn.ModuleList(
            layers.hetero(
                {
                    SURFACE_EDGE: layers.gat(
                        cfg.block_in(i),
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
            layers.norm(h, affine=True, track_running_stats=False)
            for _ in range(cfg.surface_blocks)
        )
        with warnings.catch_warnings():
            # Surfaces are no destination of the part conv by design: they are read, not updated.
            warnings.filterwarnings("ignore", message="There exist node types")
            self.part_conv = layers.hetero(
                {
                    PART_EDGE: layers.gat(
                        (h, cfg.part_in), h, negative_slope=cfg.negative_slope, add_self_loops=False
                    )
                },
                aggr="mean",
            )
        self.part_norm = layers.norm(h, affine=True, track_running_stats=False)
        if cfg.pair_readout:
            p, w = cfg.pair_readout, cfg.static_width
            self.pair_dst = nn.Linear(w, p)
            self.pair_src = nn.Linear(w, p, bias=False)
            self.pair_rel = nn.Linear(1, p, bias=False)
            self.fuse = nn.Linear(cfg.fuse_in, h)
            rounds = range(cfg.readout_rounds - 1)
            self.round_gates = nn.ModuleList(nn.Linear(h, p) for _ in rounds)
            self.round_fuses = nn.ModuleList(nn.Linear(h + p, h) for _ in rounds)
        if cfg.pair_geometry:
            self.pair_geom = nn.Sequential(
                nn.Linear(PAIR_GEOMETRY_FEATURES, cfg.pair_geometry),
                nn.LeakyReLU(cfg.negative_slope),
                nn.Linear(cfg.pair_geometry, cfg.pair_readout),
            )
        self.head = nn.Linear(h, 2 if cfg.placeable_head else 1)

    def surface_gat(self, i: int) -> nn.Module:
        return self.surface_convs[i].convs[SURFACE_EDGE]

    @property
    def part_gat(self) -> nn.Module:
        return self.part_conv.convs[PART_EDGE]

    def forward(self, data: HeteroData | Batch) -> torch.Tensor:
        """Logits of all part nodes of a (batched) Assembly Graph, shape (n_part_nodes,)."""
        surf_batch = _batch_vector(data, "surface")
        part_batch = _batch_vector(data, "part")
        x_surface = data["surface"].x
        edges = {SURFACE_EDGE: data[SURFACE_EDGE].edge_index}
        attrs = {SURFACE_EDGE: data[SURFACE_EDGE].edge_attr}
        static = x_surface  # the state-blind features: input of the first state-aware block
        for i, (conv, norm) in enumerate(zip(self.surface_convs, self.surface_norms, strict=True)):
            if self.cfg.state_blocks and i == self.cfg.first_state_block:
                src, owner = data[PART_EDGE].edge_index
                flag = torch.zeros_like(x_surface[:, 0])
                flag[src] = data["part"].x[owner, 0]
                x_surface = torch.cat([flag.unsqueeze(-1), x_surface], dim=1)
            out = conv({"surface": x_surface}, edges, edge_attr_dict=attrs)["surface"]
            x_surface = torch.tanh(norm(out, surf_batch))
            if i < self.cfg.first_state_block:
                static = x_surface
        x = {"surface": x_surface, "part": data["part"].x}
        out = self.part_conv(x, {PART_EDGE: data[PART_EDGE].edge_index})["part"]
        x_part = torch.tanh(self.part_norm(out, part_batch))
        if self.cfg.pair_readout:
            x_part = self._pair_readout(data, static, x_part)
        return self.readout(x_part)

    def readout(self, features: torch.Tensor) -> torch.Tensor:
        """Logits from part features (..., hidden): (...) with one head, (..., 2) with the
        placeable head (next step, placeable)."""
        logits = self.head(features)
        return logits if self.cfg.placeable_head else logits.squeeze(-1)

    def scores(self, logits: torch.Tensor) -> torch.Tensor:
        """The policy's next-step scores from :meth:`readout`'s logits: the sigmoid, or with
        the placeable head both outputs' sigmoids combined by `cfg.score`."""
        if self.cfg.placeable_head:
            return SCORE_RULES[self.cfg.score](F.logsigmoid(logits))
        return torch.sigmoid(logits)

    def _pair_readout(
        self, data: HeteroData | Batch, static: torch.Tensor, x_part: torch.Tensor
    ) -> torch.Tensor:
        """The relational readout of `pair_readout` as messages along surface–surface edges."""
        src, dst = data[SURFACE_EDGE].edge_index
        surface, owner = data[PART_EDGE].edge_index
        part_of = torch.empty_like(surface)
        part_of[surface] = owner
        n_own = torch.bincount(owner, minlength=x_part.shape[0]).to(static.dtype)
        other = part_of[src] != part_of[dst]
        src, dst = src[other], dst[other]
        z = self.pair_dst(static[dst]) + self.pair_src(static[src])
        z = F.leaky_relu(
            z + self.pair_rel(data[SURFACE_EDGE].edge_attr[other]), self.cfg.negative_slope
        )
        z = z / (n_own[part_of[dst]] * n_own[part_of[src]]).unsqueeze(-1)
        # Every term as (source part, destination part, feature): the surface pairs', then the
        # part pairs' geometry terms; summed into one feature per ordered part pair.
        src, dst = part_of[src], part_of[dst]
        if self.cfg.pair_geometry:
            pair_src, pair_dst = data[PAIR_EDGE].edge_index
            src, dst = torch.cat([src, pair_src]), torch.cat([dst, pair_dst])
            z = torch.cat([z, self.pair_geom(data[PAIR_EDGE].edge_attr)])
        n = x_part.shape[0]
        pairs, term_pair = torch.unique(src * n + dst, return_inverse=True)
        z = z.new_zeros(pairs.shape[0], z.shape[1]).index_add_(0, term_pair, z)
        src, dst = pairs // n, pairs % n
        placed = data["part"].x[src, 0] > 0.5
        pool = self.cfg.pool
        pooled = [_pool(z, dst, placed, n, pool), _pool(z, dst, ~placed, n, pool)]
        if pool != Pool.sum:
            others = torch.bincount(dst, minlength=n).clamp(min=1)
            pooled.append((torch.bincount(dst[placed], minlength=n) / others).unsqueeze(-1))
        x_part = torch.tanh(self.fuse(torch.cat([x_part, *pooled], dim=1)))
        every = torch.ones_like(placed)
        for gate, fuse in zip(self.round_gates, self.round_fuses, strict=True):
            message = _pool(z * gate(x_part)[src], dst, every, n, pool)
            x_part = torch.tanh(fuse(torch.cat([x_part, message], dim=1)))
        return x_part


def _pool(values: torch.Tensor, dst: torch.Tensor, keep: torch.Tensor, n: int, pool: Pool):
    """`values` (pairs, P) of the pairs where `keep`, pooled per destination part: (n, P); 0
    for a part with no such pair."""
    if pool == Pool.max:
        masked = values.masked_fill(~keep.unsqueeze(-1), -torch.inf)
        index = dst.unsqueeze(-1).expand_as(values)
        out = values.new_full((n, values.shape[1]), -torch.inf)
        out = out.scatter_reduce(0, index, masked, "amax", include_self=True)
        return out.masked_fill(out == -torch.inf, 0.0)
    out = values.new_zeros(n, values.shape[1]).index_add_(0, dst, values * keep.unsqueeze(-1))
    if pool == Pool.mean:
        out = out / torch.bincount(dst[keep], minlength=n).clamp(min=1).unsqueeze(-1)
    return out


def _batch_vector(data: HeteroData | Batch, node_type: str) -> torch.Tensor:
    store = data[node_type]
    if "batch" in store:
        return store.batch
    return torch.zeros(store.num_nodes, dtype=torch.long, device=store.x.device)


def count_parameters(net: nn.Module) -> int:
    """Number of trainable parameters (51.7 K at the paper's configuration, Sec. V-A3)."""
    return sum(p.numel() for p in net.parameters() if p.requires_grad)
