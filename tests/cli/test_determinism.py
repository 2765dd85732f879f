"""At two threads, the backward of a gather (how the network reads part and pair features by
index) repeats bit for bit once the threads are capped the project's way."""

import torch

from grace.cli.determinism import cap_threads


def _gather_gradient(index: torch.Tensor, weights: torch.Tensor) -> torch.Tensor:
    features = torch.zeros(500, 32, requires_grad=True)
    (features[index] * weights).sum().backward()
    return features.grad


def test_a_gathers_backward_repeats_exactly_with_two_threads():
    threads, deterministic = torch.get_num_threads(), torch.are_deterministic_algorithms_enabled()
    generator = torch.Generator().manual_seed(0)
    index = torch.randint(0, 500, (200_000,), generator=generator)
    weights = torch.randn(200_000, 32, generator=generator)
    try:
        cap_threads(2)
        assert torch.get_num_threads() == 2
        first = _gather_gradient(index, weights)
        assert all(torch.equal(first, _gather_gradient(index, weights)) for _ in range(5))
    finally:
        torch.set_num_threads(threads)
        torch.use_deterministic_algorithms(deterministic)
