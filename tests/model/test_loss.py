import math

import pytest
import torch

from grace.model.loss import ListwiseLoss, grace_loss, listwise_loss

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


def test_listwise_loss_ranks_the_invalid_part_below_both_valid_ones():
    # One state, three unplaced parts: 0 and 1 valid, 2 invalid and scored highest at the start.
    logits = torch.tensor([[0.0, 0.5, 2.0]], requires_grad=True)
    labels = torch.tensor([[1.0, 1.0, 0.0]])
    flags, mask = torch.zeros(1, 3), torch.ones(1, 3, dtype=torch.bool)
    optimiser = torch.optim.SGD([logits], lr=1.0)
    for _ in range(5):
        optimiser.zero_grad()
        listwise_loss(logits, labels, flags, mask).backward()
        optimiser.step()
    assert logits[0, 2] < logits[0, :2].min()


def test_listwise_loss_reads_candidates_of_states_with_a_valid_part_only():
    labels = torch.tensor([[1.0, 0.0, 0.4], [0.0, 0.0, 0.0]])  # 0.4: a graded dead-end target
    flags = torch.tensor([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])  # part 1 placed in the first state
    mask = torch.ones(2, 3, dtype=torch.bool)
    logits = torch.tensor([[1.0, 7.0, -1.0], [3.0, -2.0, 0.5]], requires_grad=True)
    loss = listwise_loss(logits, labels, flags, mask)
    # softmax over parts 0 and 2 of the first state, target part 0
    assert math.isclose(float(loss.detach()), math.log(1 + math.exp(-2.0)), rel_tol=1e-6)
    loss.backward()
    assert logits.grad[0, 1] == 0 and not logits.grad[1].any()


def test_listwise_option_adds_the_ranking_term_to_the_papers_loss():
    logits = torch.tensor([[0.0, 2.0, -1.0]])
    labels = torch.tensor([[1.0, 0.0, 1.0]])
    flags, mask = torch.zeros(1, 3), torch.ones(1, 3, dtype=torch.bool)
    paper = grace_loss(logits, labels, flags, mask, 0.3)
    ranking = listwise_loss(logits, labels, flags, mask)
    both = ListwiseLoss(rank_weight=0.5)(logits, labels, flags, mask, 0.3)
    assert math.isclose(float(both), float(paper + 0.5 * ranking), rel_tol=1e-6)
