import math

import pytest
import torch

from grace.model.loss import grace_loss

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)


def test_loss_is_weighted_bce_plus_placed_part_penalty():
    logits = torch.tensor([[0.0, 2.0, -1.0, 5.0]])
    labels = torch.tensor([[1.0, 0.0, 0.0, 0.0]])
    flags = torch.tensor([[0.0, 0.0, 1.0, 0.0]])
    mask = torch.tensor([[True, True, True, False]])  # the last node is padding
    sig = [1 / (1 + math.exp(-x)) for x in (0.0, 2.0, -1.0)]
    bce = [-math.log(sig[0]), -math.log(1 - sig[1]), -math.log(1 - sig[2])]
    expected = sum(0.7 * b for b in bce) / 3 + 0.3 * sig[2] / 3
    assert math.isclose(float(grace_loss(logits, labels, flags, mask, 0.3)), expected, rel_tol=1e-6)


def test_penalty_pushes_placed_parts_down():
    logits = torch.zeros(1, 2, requires_grad=True)
    loss = grace_loss(
        logits,
        torch.zeros(1, 2),
        torch.tensor([[1.0, 0.0]]),
        torch.ones(1, 2, dtype=torch.bool),
        0.3,
    )
    loss.backward()
    assert logits.grad[0, 0] > logits.grad[0, 1] > 0


def test_state_weights_scale_each_states_nodes():
    logits = torch.tensor([[0.0, 2.0], [1.0, -3.0]])
    labels = torch.tensor([[1.0, 0.0], [0.0, 1.0]])
    flags = torch.zeros(2, 2)
    mask = torch.tensor([[True, True], [True, False]])  # the second state has one real node
    nodes = [
        -math.log(0.5),
        -math.log(1 - 1 / (1 + math.exp(-2.0))),
        -math.log(1 - 1 / (1 + math.exp(-1.0))),
    ]
    expected = (3.0 * 0.7 * nodes[0] + 3.0 * 0.7 * nodes[1] + 0.5 * 0.7 * nodes[2]) / 3
    loss = grace_loss(logits, labels, flags, mask, 0.3, torch.tensor([3.0, 0.5]))
    assert math.isclose(float(loss), expected, rel_tol=1e-6)


def test_pos_weight_scales_only_positive_labels():
    logits = torch.tensor([[0.5, 1.5]])
    labels = torch.tensor([[1.0, 0.0]])
    flags = torch.zeros(1, 2)
    mask = torch.ones(1, 2, dtype=torch.bool)
    positive = -math.log(1 / (1 + math.exp(-0.5)))
    negative = -math.log(1 - 1 / (1 + math.exp(-1.5)))
    loss = grace_loss(logits, labels, flags, mask, 0.0, pos_weight=4.0)
    assert math.isclose(float(loss), (4.0 * positive + negative) / 2, rel_tol=1e-6)
