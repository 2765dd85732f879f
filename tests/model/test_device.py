"""Every tensor of the fast and PyG paths is made on its input's device, so `trainer=gpu` runs
the same code (docs/operations.md, "GPU").

Without a GPU: the default device is `meta` while the model runs on the CPU, so a tensor made
without a device (a `torch.zeros(n)` where `x.new_zeros(n)` was meant) lands on `meta`, and the
first operation mixing it with the CPU data fails, as it would on a GPU. With CUDA, the same
paths run on it for real."""

import numpy as np
import pytest
import torch
from hydra.utils import instantiate
from lightning.fabric.utilities.apply_func import move_data_to_device
from torch_geometric.data import Batch

from grace.cli.fit import train_module
from grace.errors import UserError
from grace.graphs.assembly_graph import state_flags, state_graph
from grace.model.grace_fast import shared_work, state_features
from grace.model.impls import PreparedAssembly
from grace.model.scoring import Scorer, evaluation_tensors

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)

PATHS = [
    ("grace", "fast"),
    ("grace_state", "fast"),  # the state-aware surface blocks
    ("grace_geometric", "fast"),  # the relational readout with pair geometry
    ("grace_geometric", "pyg"),
]


def _batch_and_module(cfg_factory, samples, model: str, impl: str):
    cfg = cfg_factory(f"model={model}", f"model/impl={impl}", "datamodule.batch_size=16")
    torch.manual_seed(0)
    module = instantiate(cfg.model)
    data = instantiate(cfg.datamodule)(
        train=samples, val=[], enc=module.enc, collate=module.impl.collate
    )
    return next(iter(data.train_dataloader())), module


def _planning_inputs(module, sample, impl: str):
    """What the planner feeds the network for all states of one assembly, made beforehand on the
    CPU (data preparation, not the network's own tensors)."""
    prepared = PreparedAssembly(sample.assembly, evaluation_tensors(module, sample.assembly))
    states = sample.truth.states
    if impl == "pyg":
        return Batch.from_data_list([state_graph(prepared.tensors, int(s)) for s in states])
    flags = state_flags(states, sample.size)
    return prepared, torch.zeros(len(states), dtype=torch.long), flags


def _plan_logits(module, inputs, impl: str) -> torch.Tensor:
    if impl == "pyg":
        return module.net(inputs)
    prepared, index, flags = inputs
    shared = shared_work(module.net, prepared.dense)
    return module.net.readout(state_features(module.net, prepared.dense, index, flags, shared))


@pytest.mark.parametrize(("model", "impl"), PATHS)
def test_no_tensor_is_made_off_its_inputs_device(cfg_factory, samples, model, impl):
    batch, module = _batch_and_module(cfg_factory, samples, model, impl)
    planning = _planning_inputs(module, samples[1], impl)
    with torch.device("meta"):  # where a tensor made without a device goes
        loss = module.loss(batch, module(batch))
        loss.backward()
        with torch.no_grad():
            logits = _plan_logits(module, planning, impl)
    assert loss.device.type == "cpu" and logits.device.type == "cpu"
    grads = [p.grad for p in module.parameters() if p.grad is not None]
    # the fast path leaves out the GAT biases that its instance norms cancel: they get no gradient
    assert len(grads) > len(list(module.parameters())) // 2
    assert all(g.device.type == "cpu" for g in grads)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device on this machine")
@pytest.mark.parametrize("impl", ["fast", "pyg"])
def test_training_and_scoring_run_on_cuda(cfg_factory, samples, impl):
    batch, module = _batch_and_module(cfg_factory, samples, "grace_geometric", impl)
    cpu_loss = module.loss(batch, module(batch))
    cuda = torch.device("cuda")
    module = module.to(cuda)
    loss = module.loss(*(lambda b: (b, module(b)))(move_data_to_device(batch, cuda)))
    assert loss.device.type == "cuda"
    torch.testing.assert_close(loss.cpu(), cpu_loss, rtol=1e-4, atol=1e-5)
    sample = samples[1]
    scores = Scorer(module)(sample.assembly, sample.truth.states)
    assert isinstance(scores, np.ndarray) and scores.shape == (len(sample.truth.states), 5)


@pytest.mark.skipif(torch.cuda.is_available(), reason="a CUDA device is present")
def test_trainer_gpu_without_a_gpu_is_one_line_with_the_fix(cfg_factory, samples, tmp_path):
    cfg = cfg_factory("trainer=gpu")
    assert (cfg.trainer.accelerator, cfg.trainer.max_epochs) == ("gpu", 16)  # the CPU's rest
    with pytest.raises(UserError, match=r"trainer.accelerator=gpu: .*; fix: trainer=cpu"):
        train_module(cfg, samples[:5], samples[5:], tmp_path / "fit")
    assert not (tmp_path / "fit").exists()


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device on this machine")
def test_trainer_gpu_fits_on_cuda(cfg_factory, samples, tmp_path):
    cfg = cfg_factory("trainer=gpu", "trainer.max_epochs=2", "trainer.enable_progress_bar=false")
    module = train_module(cfg, samples[:5], samples[5:], tmp_path / "fit")
    scores = Scorer(module)(samples[1].assembly, samples[1].truth.states)
    assert np.isfinite(scores).all()
