"""The fast exact path of GRACE: one surface embedding per assembly, dense padded attention.

(The non-paper variant `state_surfaces`, see grace_pyg.NetConfig, shares nothing across states;
it still runs on the dense tensors here, one row per state.)

The surface blocks never see the state (SPEC §4–5: no assembled flag in surface features or
surface edges), so all states of an assembly share one surface embedding. The part block's
attention for part i depends on the state only through i's own flag, which is 0 or 1: we compute
both possible part-block outputs once per assembly, and a state just selects between them before
the per-state InstanceNorm, tanh and head. The surface graph is complete, so its attention runs
on dense (assemblies × surfaces × surfaces) tensors. Same parameters as :class:`GraceNet`
(equality with the PyG path is tested to 1e-5).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from grace.graphs.dense import DenseAssemblies
from grace.model.grace_pyg import GraceNet

_EPS = 1e-5  # torch_geometric InstanceNorm default
_MASKED = -1e30


def _norm_weights(mask: torch.Tensor, dtype: torch.dtype) -> tuple[torch.Tensor, torch.Tensor]:
    """(mask, mask / count) as (..., rows, 1) floats: the masked mean is then one weighted sum."""
    m = mask.unsqueeze(-1).to(dtype)
    return m, m / m.sum(dim=-2, keepdim=True).clamp(min=1)


def _masked_instance_norm(
    x: torch.Tensor, weights: tuple[torch.Tensor, torch.Tensor], norm: torch.nn.Module
) -> torch.Tensor:
    """InstanceNorm over dim −2 counting only masked rows (biased variance, as PyG).

    `weights` comes from :func:`_norm_weights`, computed once and shared by all blocks.
    """
    m, w = weights
    centred = (x - (x * w).sum(dim=-2, keepdim=True)) * m
    var = (centred.square() * w).sum(dim=-2, keepdim=True)
    return torch.addcmul(norm.bias, centred * torch.rsqrt(var + _EPS), norm.weight)


def surface_embedding(net: GraceNet, dense: DenseAssemblies) -> torch.Tensor:
    """Surface node features after all surface blocks, (A, S, hidden); padding rows are 0.

    Written with as few tensor operations as possible: on CPU a small assembly's cost is the
    per-operation overhead, not the arithmetic (issue 3: one A7 state in ≤ 1 ms).
    """
    x = dense.surface_x
    weights = _norm_weights(dense.surface_mask, x.dtype)
    # Additive attention mask over source surfaces: padding sources get exp(−huge) = 0.
    padding = (~dense.surface_mask).to(x.dtype).unsqueeze(1) * _MASKED  # (A, 1, S_src)
    rel = dense.relation.unsqueeze(-1)  # (A, S_dst, S_src, 1)
    for i, norm in enumerate(net.surface_norms):
        gat = net.surface_gat(i)
        xl, xr = gat.lin_l(x), gat.lin_r(x)
        # The (A, S, S, hidden) pair tensor is the bulk of the work: built once, then updated
        # in place (autograd allows it: neither add nor addcmul needs its output to go back).
        z = (xr.unsqueeze(2) + xl.unsqueeze(1)).addcmul_(rel, gat.lin_edge.weight[:, 0])
        score = F.leaky_relu_(z, gat.negative_slope) @ gat.att[0, 0] + padding
        out = torch.softmax(score, dim=-1) @ xl + gat.bias
        x = torch.tanh(_masked_instance_norm(out, weights, norm))
    return x * weights[0]


def part_block_pair(
    net: GraceNet, dense: DenseAssemblies, surfaces: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Part-conv outputs (A, N, hidden) for every part unplaced (flag 0) and placed (flag 1)."""
    gat = net.part_gat
    xl = gat.lin_l(surfaces)  # (A, S, H)
    w = gat.lin_r.weight
    xr_static = F.linear(dense.part_static, w[:, 1:], gat.lin_r.bias)  # (A, N, H)
    idx = dense.surface_part.unsqueeze(-1).expand(-1, -1, xr_static.shape[-1])
    xr_of_surface = torch.gather(xr_static, 1, idx)  # (A, S, H)
    n = xr_static.shape[1]
    own = dense.surface_part.unsqueeze(1) == torch.arange(n).view(1, n, 1)  # (A, N, S)
    own = (own & dense.surface_mask.unsqueeze(1)).to(xl.dtype)
    # Both flag values at once, along a leading dimension of 2: flag 0 adds nothing.
    flag_w = torch.stack([torch.zeros_like(w[:, 0]), w[:, 0]]).view(2, 1, 1, -1)
    z = (xl + xr_of_surface).unsqueeze(0) + flag_w  # (2, A, S, H)
    score = F.leaky_relu_(z, gat.negative_slope) @ gat.att[0, 0]  # (2, A, S)
    # A part attends to its own surfaces only: the others get exp(−huge) = 0.
    score = score.unsqueeze(2) + (1.0 - own) * _MASKED  # (2, A, N, S)
    out = (torch.softmax(score, dim=-1) * own) @ xl + gat.bias  # (2, A, N, H)
    return out[0], out[1]


def state_part_features(
    net: GraceNet,
    pair: tuple[torch.Tensor, torch.Tensor],
    part_mask: torch.Tensor,
    state_assembly: torch.Tensor,
    flags: torch.Tensor,
) -> torch.Tensor:
    """Part features after the part block for T states, (T, N, hidden).

    `state_assembly` (T,) indexes the assembly of each state, `flags` (T, N) its assembled flags.
    """
    out0, out1 = pair[0][state_assembly], pair[1][state_assembly]
    h = torch.addcmul(out0, flags.unsqueeze(-1), out1 - out0)
    weights = _norm_weights(part_mask[state_assembly], h.dtype)
    return torch.tanh(_masked_instance_norm(h, weights, net.part_norm))


def per_state(
    dense: DenseAssemblies, state_assembly: torch.Tensor, flags: torch.Tensor
) -> DenseAssemblies:
    """One row per state, surface inputs prefixed with their part's flag (`state_surfaces`)."""
    surface_part = dense.surface_part[state_assembly]
    surface_mask = dense.surface_mask[state_assembly]
    owner_flag = torch.gather(flags, 1, surface_part) * surface_mask
    return DenseAssemblies(
        surface_x=torch.cat([owner_flag.unsqueeze(-1), dense.surface_x[state_assembly]], dim=-1),
        relation=dense.relation[state_assembly],
        surface_mask=surface_mask,
        surface_part=surface_part,
        part_static=dense.part_static[state_assembly],
        part_mask=dense.part_mask[state_assembly],
    )


def state_features(
    net: GraceNet,
    dense: DenseAssemblies,
    state_assembly: torch.Tensor,
    flags: torch.Tensor,
    pair: tuple[torch.Tensor, torch.Tensor] | None = None,
) -> torch.Tensor:
    """Part features (T, N, hidden) for T states of the assemblies in `dense`.

    `pair` may pass a cached :func:`part_block_pair` of `dense`. With `state_surfaces` the surface
    blocks see the state, nothing is shared and every state gets its own dense surface pass.
    """
    if net.cfg.state_surfaces:
        rows = per_state(dense, state_assembly, flags)
        pair = part_block_pair(net, rows, surface_embedding(net, rows))
        index = torch.arange(len(flags))
        return state_part_features(net, pair, rows.part_mask, index, flags)
    if pair is None:
        pair = part_block_pair(net, dense, surface_embedding(net, dense))
    return state_part_features(net, pair, dense.part_mask, state_assembly, flags)


def fast_logits(
    net: GraceNet, dense: DenseAssemblies, state_assembly: torch.Tensor, flags: torch.Tensor
) -> torch.Tensor:
    """Part logits (T, N) for T states of the assemblies in `dense` (padding parts arbitrary)."""
    return net.head(state_features(net, dense, state_assembly, flags)).squeeze(-1)
