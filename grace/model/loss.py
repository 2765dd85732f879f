"""The GRACE loss per part node (paper Eq. 4–5, docs/training.md) and a listwise ranking loss
per state (not in the paper, `model/loss=listwise`)."""

from __future__ import annotations

from dataclasses import dataclass

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


FILL = -1e9
"""Logit given to the parts that are no candidates (placed parts, padding) before the softmax:
their probability is 0, and, finite, it keeps the gradient of a state without candidates 0."""


def listwise_loss(
    logits: torch.Tensor,
    labels: torch.Tensor,
    flags: torch.Tensor,
    mask: torch.Tensor,
    weights: torch.Tensor | None = None,
) -> torch.Tensor:
    """Mean over states with a valid next part of the softmax cross-entropy between the state's
    candidate parts (real, unplaced) and the uniform distribution over its valid next parts.

    A valid next part (label 1) is one that some complete order places next: the target is what
    every feasible order says of the state at once. Graded dead-end targets (< 1) count as
    invalid. The loss reads only differences of logits within a state, so what it teaches is
    the ranking a planner thresholded relative to the state's best reads (docs/training.md,
    "Ranking"). States without a valid next part (dead ends, infeasible assemblies) add
    nothing. `weights` (T,) scales each state, as in :func:`grace_loss`.
    """
    candidates = mask & (flags < 0.5)
    positive = candidates & (labels > 0.5)
    count = positive.sum(dim=1)
    log_p = torch.log_softmax(logits.masked_fill(~candidates, FILL), dim=1)
    per_state = -(log_p.masked_fill(~positive, 0.0)).sum(dim=1) / count.clamp(min=1)
    if weights is not None:
        per_state = per_state * weights
    ranked = count > 0
    if not ranked.any():
        return logits.sum() * 0.0
    return per_state[ranked].mean()


@dataclass(frozen=True)
class ListwiseLoss:
    """`model/loss=listwise` (not in the paper): the paper's loss plus `rank_weight` times the
    listwise one of the next-step output. The paper's term keeps the scores absolute (a dead end
    scores low everywhere, so "no sequence" still means infeasible); the listwise term ranks the
    valid parts of every state above the others whatever the assembly's size."""

    rank_weight: float = 1.0

    def __call__(
        self,
        logits: torch.Tensor,
        labels: torch.Tensor,
        flags: torch.Tensor,
        mask: torch.Tensor,
        delta: float,
        weights: torch.Tensor | None = None,
    ) -> torch.Tensor:
        paper = grace_loss(logits, labels, flags, mask, delta, weights)
        return paper + self.rank_weight * listwise_loss(logits, labels, flags, mask, weights)
