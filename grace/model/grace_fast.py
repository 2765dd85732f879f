"""The fast exact path of GRACE: one surface embedding per assembly, dense padded attention.

The surface blocks never see the state (docs/assembly-graph.md: no assembled flag in surface
features or surface edges), so all states of an assembly share one surface embedding. The part
block's attention for part i depends on the state only through i's own flag, which is 0 or 1: we
compute both possible part-block outputs once per assembly, and a state just selects between
them before the per-state InstanceNorm, tanh and head. The surface graph is complete, so its
attention runs on dense (assemblies × surfaces × surfaces) tensors. Same parameters as
:class:`GraceNet` (equality with the PyG path is tested to 1e-5).

The non-paper variant `state_blocks = k` (grace_pyg.NetConfig) shares the first
`surface_blocks − k` blocks across states. The first state-aware block sees the state only
through one 0/1 flag per surface (its part's), added to a shared input: its attention logit for a
surface pair takes one of four values, by the two flags, all computed once per assembly
(:class:`FlagAttention`), so a state costs a selection, a softmax and one matrix product instead
of its own (surfaces × surfaces × hidden) pair tensor. The further k − 1 blocks and the part
block run once per state, on dense tensors (one row per state).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F

from grace.graphs.assembly_graph import state_flags
from grace.graphs.dense import DenseAssemblies
from grace.model.grace_pyg import GraceNet, Layers, Pool

_EPS = 1e-5  # torch_geometric InstanceNorm default
_MASKED = -1e30


class GATv2Weights(torch.nn.Module):
    """The parameters of PyG's one-head GATv2Conv under its names (what the fast path reads),
    without PyG. Self loops and their fill value shape PyG's message passing only."""

    def __init__(
        self,
        in_channels: int | tuple[int, int],
        out_channels: int,
        negative_slope: float = 0.2,
        edge_dim: int | None = None,
        add_self_loops: bool = True,
        fill_value: float = 0.0,
    ) -> None:
        super().__init__()
        src, dst = (in_channels, in_channels) if isinstance(in_channels, int) else in_channels
        self.negative_slope = negative_slope
        self.lin_l = torch.nn.Linear(src, out_channels)
        self.lin_r = torch.nn.Linear(dst, out_channels)
        self.att = torch.nn.Parameter(torch.empty(1, 1, out_channels))
        if edge_dim is not None:
            self.lin_edge = torch.nn.Linear(edge_dim, out_channels, bias=False)
        self.bias = torch.nn.Parameter(torch.empty(out_channels))


class EdgeModules(torch.nn.ModuleDict):
    """Modules keyed by edge type, named as PyG's HeteroConv names them (`<src___rel___dst>`)."""

    def __init__(self, modules: dict[tuple[str, ...], torch.nn.Module]) -> None:
        super().__init__({self.name(edge): module for edge, module in modules.items()})

    @staticmethod
    def name(edge: tuple[str, ...]) -> str:
        return f"<{'___'.join(edge)}>"

    def __getitem__(self, edge: tuple[str, ...]) -> torch.nn.Module:
        return super().__getitem__(self.name(edge))


class HeteroWeights(torch.nn.Module):
    """The parameters of PyG's HeteroConv (its convs), without PyG; `aggr` shapes PyG's message
    passing only."""

    def __init__(self, convs: dict[tuple[str, ...], torch.nn.Module], aggr: str = "sum") -> None:
        super().__init__()
        self.convs = EdgeModules(convs)


class InstanceNormWeights(torch.nn.Module):
    """The parameters of PyG's affine InstanceNorm without running statistics (GraceNet's
    norms), without PyG."""

    def __init__(self, channels: int, affine: bool, track_running_stats: bool) -> None:
        super().__init__()
        if not affine or track_running_stats:
            raise ValueError("holds an affine norm without running statistics only")
        self.weight = torch.nn.Parameter(torch.empty(channels))
        self.bias = torch.nn.Parameter(torch.empty(channels))


WEIGHT_LAYERS = Layers(GATv2Weights, HeteroWeights, InstanceNormWeights)
"""GraceNet's layers as plain parameter holders: a network to load weights into and run on the
fast path, which never loads PyG (grace_pyg.GraceNet)."""


NormWeights = tuple[torch.Tensor, torch.Tensor] | None
"""(mask, mask / count) as (..., rows, 1) floats, or None where every row is real."""


def _norm_weights(mask: torch.Tensor, dtype: torch.dtype) -> NormWeights:
    """(mask, mask / count) as (..., rows, 1) floats: the masked mean is then one weighted sum.
    None for a mask of one assembly, which has no padding (DenseAssemblies.stack pads to the
    largest assembly)."""
    if mask.shape[0] == 1:
        return None
    m = mask.unsqueeze(-1).to(dtype)
    return m, m / m.sum(dim=-2, keepdim=True).clamp(min=1)


def _instance_norm(x: torch.Tensor, weights: NormWeights, norm: torch.nn.Module) -> torch.Tensor:
    """InstanceNorm over dim −2 counting only masked rows (biased variance, as PyG).

    `weights` comes from :func:`_norm_weights`, computed once and shared by all blocks; without
    padding, a group norm of the transpose does it in one kernel (torch's instance_norm takes
    twice as long on these small tensors). The GAT biases that precede every such norm are
    constant over the rows it centres, so they cancel and are left out.
    """
    if weights is None:  # one group per channel: an instance norm over the rows, one kernel
        channels = x.transpose(-1, -2)
        return F.group_norm(channels, x.shape[-1], norm.weight, norm.bias, _EPS).transpose(-1, -2)
    m, w = weights
    centred = (x - (x * w).sum(dim=-2, keepdim=True)) * m
    var = (centred.square() * w).sum(dim=-2, keepdim=True)
    return torch.addcmul(norm.bias, centred * torch.rsqrt(var + _EPS), norm.weight)


def _linear(layer: torch.nn.Linear, x: torch.Tensor) -> torch.Tensor:
    """`layer(x)` without the module call's hooks: a few microseconds per layer, which is a
    tenth of a warm next-step query."""
    return F.linear(x, layer.weight, layer.bias)


def _by_state(x: torch.Tensor, state_assembly: torch.Tensor) -> torch.Tensor:
    """Per-assembly `x` (A, ...) as one row per state: gathered, or with a single assembly left
    to broadcast (no copy)."""
    return x if x.shape[0] == 1 else x[state_assembly]


def run_surface_blocks(
    net: GraceNet, dense: DenseAssemblies, x: torch.Tensor, blocks: range
) -> torch.Tensor:
    """Surface features (A, S, hidden) after surface blocks `blocks` from input `x`.

    Written with as few tensor operations as possible: on CPU a small assembly's cost is the
    per-operation overhead, not the arithmetic (a cold next step of one new A7 assembly within a
    millisecond); a single assembly has no padding to mask.
    """
    weights = _norm_weights(dense.surface_mask, x.dtype)
    # Additive attention mask over source surfaces: padding sources get exp(−huge) = 0.
    padding = 0.0
    if weights is not None:
        padding = (~dense.surface_mask).to(x.dtype).unsqueeze(1) * _MASKED  # (A, 1, S_src)
    rel = dense.relation.unsqueeze(-1)  # (A, S_dst, S_src, 1)
    for i in blocks:
        gat = net.surface_gat(i)
        xl, xr = _linear(gat.lin_l, x), _linear(gat.lin_r, x)
        # The (A, S, S, hidden) pair tensor is the bulk of the work: built once, then updated
        # in place (autograd allows it: neither add nor addcmul needs its output to go back).
        z = (xr.unsqueeze(2) + xl.unsqueeze(1)).addcmul_(rel, gat.lin_edge.weight[:, 0])
        score = F.leaky_relu_(z, gat.negative_slope) @ gat.att[0, 0] + padding
        out = torch.softmax(score, dim=-1) @ xl  # + gat.bias: cancelled by the norm
        x = torch.tanh(_instance_norm(out, weights, net.surface_norms[i]))
    return x if weights is None else x * weights[0]


def surface_embedding(net: GraceNet, dense: DenseAssemblies) -> torch.Tensor:
    """The state-independent surface features, (A, S, ·): after every block that is blind to
    the state (all of them in the paper's network); padding rows are 0."""
    return run_surface_blocks(net, dense, dense.surface_x, range(net.cfg.first_state_block))


def _part_inputs(
    net: GraceNet, dense: DenseAssemblies, surfaces: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The part conv's flag-free terms: lin_l of the surfaces (A, S, H), lin_r of each
    surface's part without its flag (A, S, H), and surface ownership (A, N, S)."""
    gat = net.part_gat
    xl = _linear(gat.lin_l, surfaces)
    w = gat.lin_r.weight
    xr_static = F.linear(dense.part_static, w[:, 1:], gat.lin_r.bias)  # (A, N, H)
    idx = dense.surface_part.unsqueeze(-1).expand(-1, -1, xr_static.shape[-1])
    return xl, torch.gather(xr_static, 1, idx), dense.ownership


def _part_outputs(
    net: GraceNet, z: torch.Tensor, xl: torch.Tensor, own: torch.Tensor
) -> torch.Tensor:
    """Part-conv outputs (..., A, N, H) from the pre-activation `z` (..., A, S, H)."""
    gat = net.part_gat
    score = F.leaky_relu_(z, gat.negative_slope) @ gat.att[0, 0]  # (..., A, S)
    # A part attends to its own surfaces only: the others get exp(−huge) = 0.
    score = score.unsqueeze(-2) + (1.0 - own) * _MASKED  # (..., A, N, S)
    return (torch.softmax(score, dim=-1) * own) @ xl  # + gat.bias: cancelled by the part norm


def part_block_pair(
    net: GraceNet, dense: DenseAssemblies, surfaces: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Part-conv outputs (A, N, hidden) of every part unplaced (flag 0), and what placing it
    adds (the flag-1 output minus the flag-0 one)."""
    xl, xr_of_surface, own = _part_inputs(net, dense, surfaces)
    w0 = net.part_gat.lin_r.weight[:, 0]
    # Both flag values at once, along a leading dimension of 2: flag 0 adds nothing.
    flag_w = torch.stack([torch.zeros_like(w0), w0]).view(2, 1, 1, -1)
    out = _part_outputs(net, (xl + xr_of_surface).unsqueeze(0) + flag_w, xl, own)
    return out[0], out[1] - out[0]


def part_block_states(
    net: GraceNet, rows: DenseAssemblies, surfaces: torch.Tensor, owner_flag: torch.Tensor
) -> torch.Tensor:
    """Part-conv outputs (T, N, hidden) of one state per row, `owner_flag` (T, S) the flag of
    each surface's part: only the state's own flags, where the pair above computes both."""
    xl, xr_of_surface, own = _part_inputs(net, rows, surfaces)
    w0 = net.part_gat.lin_r.weight[:, 0]
    return _part_outputs(
        net, torch.addcmul(xl + xr_of_surface, owner_flag.unsqueeze(-1), w0), xl, own
    )


def part_norm(net: GraceNet, h: torch.Tensor, part_mask: torch.Tensor) -> torch.Tensor:
    """The part block's InstanceNorm over each state's real parts, then tanh; `part_mask` has
    one row per state, or a single row (one assembly, no padding)."""
    return torch.tanh(_instance_norm(h, _norm_weights(part_mask, h.dtype), net.part_norm))


def state_part_features(
    net: GraceNet,
    pair: tuple[torch.Tensor, torch.Tensor],
    part_mask: torch.Tensor,
    state_assembly: torch.Tensor,
    flags: torch.Tensor,
) -> torch.Tensor:
    """Part features after the part block for T states, (T, N, hidden), from
    :func:`part_block_pair`'s `pair`.

    `state_assembly` (T,) indexes the assembly of each state, `flags` (T, N) its assembled flags.
    """
    unplaced, placing = (_by_state(x, state_assembly) for x in pair)
    h = torch.addcmul(unplaced, flags.unsqueeze(-1), placing)
    return part_norm(net, h, _by_state(part_mask, state_assembly))


@dataclass
class FlagAttention:
    """What the first state-aware surface block shares across the states of an assembly.

    Its input is [flag, static]: lin_l and lin_r are each the static part plus flag × one weight
    column, so GATv2's logit LeakyReLU(xr_dst + xl_src + e) @ att of a surface pair depends on
    the state only through the two flags.
    """

    logits: torch.Tensor  # (A, S, S, 4) attention logit for (dst flag, src flag) = 2·dst + src
    values: torch.Tensor  # (A, S, hidden) lin_l of the static input (flag 0)


def flag_attention(net: GraceNet, dense: DenseAssemblies, static: torch.Tensor) -> FlagAttention:
    """The four attention logits of every surface pair of the first state-aware block."""
    gat = net.surface_gat(net.cfg.first_state_block)
    wl, wr = gat.lin_l.weight, gat.lin_r.weight
    xl = F.linear(static, wl[:, 1:], gat.lin_l.bias)
    xr = F.linear(static, wr[:, 1:], gat.lin_r.bias)
    z = (xr.unsqueeze(2) + xl.unsqueeze(1)).addcmul_(
        dense.relation.unsqueeze(-1), gat.lin_edge.weight[:, 0]
    )
    att = gat.att[0, 0]
    shifts = (None, wl[:, 0], wr[:, 0], wr[:, 0] + wl[:, 0])  # by 2·dst flag + src flag
    logits = [
        F.leaky_relu(z if shift is None else z + shift, gat.negative_slope) @ att
        for shift in shifts
    ]
    return FlagAttention(torch.stack(logits, dim=-1), xl)


def first_state_block(
    net: GraceNet,
    rows: DenseAssemblies,
    shared: FlagAttention,
    state_assembly: torch.Tensor,
    owner_flag: torch.Tensor,
) -> torch.Tensor:
    """Surface features (T, S, hidden) after the first state-aware block for T states, from
    `shared`; `rows` holds one row per state, `owner_flag` (T, S) each surface's part flag."""
    gat = net.surface_gat(net.cfg.first_state_block)
    t, s = owner_flag.shape
    # Flat index into logits (A, S, S, 4): one gather, no (T, S, S, 4) copy.
    pair = torch.arange(s * s, device=owner_flag.device).view(1, s, s) * 4
    choice = (2 * owner_flag.unsqueeze(2) + owner_flag.unsqueeze(1)).long()
    index = state_assembly.view(t, 1, 1) * (s * s * 4) + pair + choice
    padding = (~rows.surface_mask).to(owner_flag.dtype).unsqueeze(1) * _MASKED
    attention = torch.softmax(torch.take(shared.logits, index) + padding, dim=-1)  # (T, S, S)
    out = attention @ shared.values[state_assembly]
    out = out + (attention @ owner_flag.unsqueeze(-1)) * gat.lin_l.weight[:, 0]  # bias cancels
    weights = _norm_weights(rows.surface_mask, out.dtype)
    x = torch.tanh(_instance_norm(out, weights, net.surface_norms[net.cfg.first_state_block]))
    return x if weights is None else x * weights[0]


def per_state(
    dense: DenseAssemblies, state_assembly: torch.Tensor, flags: torch.Tensor
) -> tuple[DenseAssemblies, torch.Tensor]:
    """One row per state (its assembly's tensors) and the flag of each surface's part, (T, S)."""
    surface_part = dense.surface_part[state_assembly]
    surface_mask = dense.surface_mask[state_assembly]
    owner_flag = torch.gather(flags, 1, surface_part) * surface_mask
    rows = DenseAssemblies(
        surface_x=dense.surface_x[state_assembly],
        relation=dense.relation[state_assembly],
        surface_mask=surface_mask,
        surface_part=surface_part,
        part_static=dense.part_static[state_assembly],
        part_mask=dense.part_mask[state_assembly],
        pair_geometry=dense.pair_geometry[state_assembly],
        ownership=dense.ownership[state_assembly],
    )
    return rows, owner_flag


@dataclass
class SharedWork:
    """What all states of the assemblies in a DenseAssemblies share, cached between calls."""

    static: torch.Tensor  # (A, S, ·) state-blind surface features
    pair: tuple[torch.Tensor, torch.Tensor] | None  # part_block_pair's (no state_blocks)
    flag_attention: FlagAttention | None  # the first state-aware block's logits (state_blocks)
    relations: torch.Tensor | None  # (A, N_src, N_dst, pair_readout) part-pair features, if any
    relation_totals: torch.Tensor | None  # (A, N_dst, P) relations summed over sources (no max)


def pair_relations(net: GraceNet, dense: DenseAssemblies, static: torch.Tensor) -> torch.Tensor:
    """Part-pair features of the pair readout (grace_pyg.NetConfig), (A, N, N, pair_readout),
    source part first (`[a, m, n]` is what part n reads from part m: the layout that lets a state
    sum over sources with contiguous slices): the mean over surface pairs of the two parts, plus
    the pair's geometry term if the net reads it, 0 on the diagonal and on padding."""
    dst, src = _linear(net.pair_dst, static), F.linear(static, net.pair_src.weight)
    z = (dst.unsqueeze(2) + src.unsqueeze(1)).addcmul_(
        dense.relation.unsqueeze(-1), net.pair_rel.weight[:, 0]
    )  # pair_rel has one input and no bias: relation × its weight column
    z = F.leaky_relu_(z, net.cfg.negative_slope)  # (A, S_dst, S_src, P)
    a, s, _, p = z.shape
    n = dense.part_mask.shape[1]
    own = dense.ownership
    own = own / own.sum(dim=-1, keepdim=True).clamp(min=1)  # mean over own surfaces
    # [a, m, n] = Σ_s Σ_t own[n, s] z[s, t] own[m, t], as two batched products (an einsum of
    # the three takes three times as long, forward and backward).
    by_dst = torch.bmm(own, z.view(a, s, s * p)).view(a, n, s, p)  # [a, n, t]
    relations = torch.bmm(own, by_dst.transpose(1, 2).reshape(a, s, n * p)).view(a, n, n, p)
    if net.cfg.pair_geometry:
        relations = relations + net.pair_geom(dense.pair_geometry)
    pairs = 1 - torch.eye(n, dtype=z.dtype, device=z.device)
    if a > 1:  # no pairs with padding parts
        mask = dense.part_mask.to(z.dtype)
        pairs = mask.unsqueeze(2) * mask.unsqueeze(1) * pairs
    return relations * pairs.unsqueeze(-1)


def shared_work(net: GraceNet, dense: DenseAssemblies) -> SharedWork:
    """Compute the state-independent part of the network once for `dense`."""
    static = surface_embedding(net, dense)
    if net.cfg.state_blocks:
        pair, flags = None, flag_attention(net, dense, static)
    else:
        pair, flags = part_block_pair(net, dense, static), None
    relations, totals = None, None
    if net.cfg.pair_readout:
        relations = pair_relations(net, dense, static)
        totals = None if net.cfg.pool == Pool.max else relations.sum(dim=1)
    return SharedWork(static, pair, flags, relations, totals)


def pair_readout(
    net: GraceNet,
    shared: SharedWork,
    dense: DenseAssemblies,
    state_assembly: torch.Tensor,
    flags: torch.Tensor,
    h: torch.Tensor,
) -> torch.Tensor:
    """Fuse the pools of pair features over placed and over unplaced other parts into `h`, then
    run the further readout rounds (grace_pyg.NetConfig, `pool`).

    Sums over source parts as a batched product and as multiply-then-sum over contiguous source
    slices: on the CPU both are several times faster than einsum, which loops over tiny matrices
    (one per state and channel) here. The states of a single assembly (planning) share its pair
    features by broadcasting, without a copy per state."""
    t, n = flags.shape
    pool = net.cfg.pool
    rel = _by_state(shared.relations, state_assembly)  # (T or 1, N_src, N_dst, P)
    if pool == Pool.max:
        apart = _apart_bias(_by_state(dense.part_mask, state_assembly), rel.dtype)
        placed, zero = flags > 0.5, torch.zeros_like(flags)  # by source part
        only_placed = zero.masked_fill(~placed, -torch.inf).view(t, n, 1, 1)
        only_unplaced = zero.masked_fill(placed, -torch.inf).view(t, n, 1, 1)
        pooled = [_max(rel + (apart + only_placed)), _max(rel + (apart + only_unplaced))]
    else:
        if rel.shape[0] == 1:
            placed = (flags @ rel.view(n, -1)).view(t, n, -1)
        else:
            placed = torch.bmm(flags.unsqueeze(1), rel.view(t, n, -1)).view(t, n, -1)
        pooled = [placed, _by_state(shared.relation_totals, state_assembly) - placed]
    if pool != Pool.sum:
        real = _by_state(dense.part_mask, state_assembly).to(flags.dtype)
        others = (real.sum(dim=-1, keepdim=True) - real).clamp(min=1)  # (T or 1, N_dst)
        placed_others = flags.sum(dim=-1, keepdim=True) - flags
        if pool == Pool.mean:
            pooled[0] = pooled[0] / placed_others.clamp(min=1).unsqueeze(-1)
            pooled[1] = pooled[1] / (others - placed_others).clamp(min=1).unsqueeze(-1)
        pooled.append((placed_others / others).unsqueeze(-1))
    h = torch.tanh(_linear(net.fuse, torch.cat([h, *pooled], dim=-1)))
    for gate, fuse in zip(net.round_gates, net.round_fuses, strict=True):
        if pool == Pool.max:
            message = _max(torch.addcmul(apart, rel, _linear(gate, h).unsqueeze(2)))
        else:
            message = (rel * _linear(gate, h).unsqueeze(2)).sum(dim=1)
            if pool == Pool.mean:
                message = message / others.unsqueeze(-1)
        h = torch.tanh(_linear(fuse, torch.cat([h, message], dim=-1)))
    return h


def _apart_bias(real: torch.Tensor, dtype: torch.dtype) -> torch.Tensor:
    """(T, N_src, N_dst, 1): −inf where (source, destination) is not an ordered pair of two
    different real parts (`real`: (T, N) bool), 0 where it is; built once per call.

    The pools mask by adding such biases, not by `masked_fill`: with a bool mask broadcast over
    the channels, `masked_fill` is several times slower on the CPU than a broadcast add
    (`python -m grace.model.timing`, docs/planning.md "Large frames"), and the result is the
    same for finite values (x + 0 = x, x − inf = −inf)."""
    same = torch.eye(real.shape[-1], dtype=torch.bool, device=real.device)
    apart = same | ~(real.unsqueeze(-1) & real.unsqueeze(-2))
    return (
        torch.zeros(apart.shape, dtype=dtype, device=real.device)
        .masked_fill_(apart, -torch.inf)
        .unsqueeze(-1)
    )


def _max(values: torch.Tensor) -> torch.Tensor:
    """Max of `values` (T, N_src, N_dst, P) over the sources, the masked ones −inf by their
    bias; 0 for a destination with none left (only those come out −inf; a NaN or +inf
    stays)."""
    out = values.amax(dim=1)
    return torch.nan_to_num(out, nan=torch.nan, posinf=torch.inf, neginf=0.0)


def state_features(
    net: GraceNet,
    dense: DenseAssemblies,
    state_assembly: torch.Tensor,
    flags: torch.Tensor,
    shared: SharedWork | None = None,
) -> torch.Tensor:
    """Part features (T, N, hidden) for T states of the assemblies in `dense`.

    `shared` may pass a cached :func:`shared_work` of `dense`.
    """
    if shared is None:
        shared = shared_work(net, dense)
    cfg = net.cfg
    if shared.pair is not None:
        h = state_part_features(net, shared.pair, dense.part_mask, state_assembly, flags)
    else:
        rows, owner_flag = per_state(dense, state_assembly, flags)
        x = first_state_block(net, rows, shared.flag_attention, state_assembly, owner_flag)
        x = run_surface_blocks(net, rows, x, range(cfg.first_state_block + 1, cfg.surface_blocks))
        h = part_norm(net, part_block_states(net, rows, x, owner_flag), rows.part_mask)
    if shared.relations is not None:
        h = pair_readout(net, shared, dense, state_assembly, flags, h)
    return h


def one_assembly_states(
    dense: DenseAssemblies, states: torch.Tensor | np.ndarray
) -> tuple[torch.Tensor, torch.Tensor]:
    """The assembly index (all 0) and the assembled flags of `states` (bitmasks, 1-D) of the one
    assembly in `dense`, on its device: the state inputs of :func:`fast_logits`."""
    states = torch.as_tensor(states, dtype=torch.int64, device=dense.part_mask.device)
    flags = state_flags(states, dense.part_mask.shape[1], dense.surface_x.dtype)
    return torch.zeros_like(states), flags


def planning_scores(
    net: GraceNet, dense: DenseAssemblies, states: torch.Tensor, shared: SharedWork
) -> torch.Tensor:
    """Next-step scores (T, N) of T states (bitmasks, int64) of the one assembly in `dense`,
    from its `shared` work: a planner's query from bitmask to score, so that compiled it is one
    call with no tensor work around it."""
    return net.scores(fast_logits(net, dense, *one_assembly_states(dense, states), shared))


def first_planning_scores(
    net: GraceNet, dense: DenseAssemblies, states: torch.Tensor
) -> tuple[SharedWork, torch.Tensor]:
    """:func:`shared_work` of `dense` and :func:`planning_scores` of `states` from it: a cold
    query's whole work in one call (one compiled graph instead of two)."""
    shared = shared_work(net, dense)
    return shared, planning_scores(net, dense, states, shared)


def fast_logits(
    net: GraceNet,
    dense: DenseAssemblies,
    state_assembly: torch.Tensor,
    flags: torch.Tensor,
    shared: SharedWork | None = None,
) -> torch.Tensor:
    """Part logits (T, N), or (T, N, 2) with the placeable head, for T states of the assemblies
    in `dense` (padding parts arbitrary); `shared` as in :func:`state_features`."""
    return net.readout(state_features(net, dense, state_assembly, flags, shared))
