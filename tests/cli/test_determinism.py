"""At two threads, the backward of a gather (how the network reads part and pair features by
index) repeats bit for bit once the threads are capped the project's way; the seeding is
Lightning's, without importing Lightning."""

import os
import random
import subprocess
import sys

import numpy as np
import pytest
import torch

from grace.cli.determinism import cap_threads, seed_all


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


def _draws() -> tuple:
    return (
        random.random(),
        np.random.random(3).tolist(),
        torch.rand(3).tolist(),
        os.environ["PL_GLOBAL_SEED"],
        os.environ["PL_SEED_WORKERS"],
    )


def test_seed_all_leaves_what_lightnings_seed_everything_leaves(monkeypatch):
    from lightning.pytorch import seed_everything

    monkeypatch.setenv("PL_GLOBAL_SEED", "")  # restored after the test, as the generators are
    monkeypatch.setenv("PL_SEED_WORKERS", "")
    state = random.getstate(), np.random.get_state(), torch.get_rng_state()
    try:
        for seed in (0, 7, 2**32 - 1):
            seed_everything(seed, workers=True, verbose=False)
            theirs = _draws()
            seed_all(seed)
            assert _draws() == theirs
    finally:
        random.setstate(state[0])
        np.random.set_state(state[1])
        torch.set_rng_state(state[2])


CAPPED = (
    "import os, sys, torch\n"
    "from grace.cli.determinism import cap_threads\n"
    "cap_threads(1)\n"
    "assert 'torch._inductor.config' not in sys.modules\n"
    "assert torch.are_deterministic_algorithms_enabled()\n"
    "assert torch.is_deterministic_algorithms_warn_only_enabled()\n"
)
"""A process that caps its threads before torch.compile's stack is loaded."""


def _run(code: str) -> None:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_capping_without_inductor_sets_the_kernels_flag_and_leaves_inductors_for_its_import():
    """Where torch.compile's stack is not loaded, cap_threads sets what
    torch.use_deterministic_algorithms sets without importing it: the kernels' flag, and the
    variable inductor's config reads its deterministic mode from."""
    _run(CAPPED + "assert os.environ['TORCHINDUCTOR_DETERMINISTIC'] == '1'\n")


@pytest.mark.slow
def test_inductor_loaded_after_capping_is_deterministic():
    _run(CAPPED + "import torch._inductor.config as inductor\nassert inductor.deterministic\n")
