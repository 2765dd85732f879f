"""The GRACE loss per part node (paper Eq. 4–5, docs/training.md)."""

from __future__ import annotations

import torch
import torch.nn.functional as F


def grace_loss(
    logits: torch.Tensor,
    labels: torch.Tensor,
    flags: torch.Tensor,
    mask: torch.Tensor,
    delta: float,
    weights: torch.Tensor | None = None,
    pos_weight: float = 1.0,
) -> torch.Tensor:
    """Mean over real part nodes of (1−δ)·BCE(y, ŷ) + δ·ŷ·assembled-flag.

    `weights` (T,), if given, scales each state's nodes (step balancing, docs/training.md);
    `pos_weight` scales the BCE of positive labels (not in the paper; the placeable output's, see
    GraceModule).

    The regulariser pushes scores of already placed parts to 0 (paper Eq. 5); BCE is computed from
    logits for numerical stability, which is the same function as BCE on the sigmoid.
    """
    weight_positives = None if pos_weight == 1.0 else logits.new_tensor(pos_weight)
    bce = F.binary_cross_entropy_with_logits(
        logits, labels, reduction="none", pos_weight=weight_positives
    )
    per_node = (1.0 - delta) * bce + delta * torch.sigmoid(logits) * flags
    if weights is not None:
        per_node = per_node * weights.unsqueeze(1)
    return per_node[mask].mean()
