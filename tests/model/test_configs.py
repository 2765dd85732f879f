import pytest
import torch
from hydra.errors import InstantiationException
from hydra.utils import instantiate

from grace import CONF_DIR
from grace.model.grace_fast import WEIGHT_LAYERS
from grace.model.grace_pyg import GraceNet, count_parameters
from grace.model.impls import FastImpl
from grace.model.module import GraceModule

MODELS = sorted(p.stem for p in (CONF_DIR / "model").glob("*.yaml"))


def test_every_ablation_row_has_a_config():
    assert {
        "grace", "pe_random", "pe_none", "perm_parts_test", "perm_surfaces_test",
        "perm_parts_train_test", "perm_surfaces_train_test",
    } <= set(MODELS)  # fmt: skip


# Variants beyond the paper; every other model config is the paper's network (51,701 parameters).
EXTENDED = {
    "grace_state": 51_889,
    "grace_relational": 132_781,
    "grace_geometric": 137_178,
    "cell_oracle": 137_178 + 10 * 94,  # grace_geometric, 10 more part inputs to the part conv
}


@pytest.mark.parametrize(
    "name",
    [pytest.param(m, marks=pytest.mark.slow) if m.startswith("perm_") else m for m in MODELS],
)  # the permutation variants differ from grace.yaml only in the encoding's options
def test_model_configs_build_the_same_network(cfg_factory, name):
    module = instantiate(cfg_factory(f"model={name}").model)
    assert isinstance(module, GraceModule) and isinstance(module.impl, FastImpl)
    assert module.name == name
    assert count_parameters(module.net) == EXTENDED.get(name, 51_701)
    # Planning builds it from parameter holders (grace/model/checkpoints.py): every parameter of
    # the PyG-built network, under its name and shape, and nothing else.
    with torch.device("meta"):
        held = GraceNet(module.net.cfg, WEIGHT_LAYERS)
    shapes = {key: tuple(w.shape) for key, w in module.net.state_dict().items()}
    assert {key: tuple(w.shape) for key, w in held.state_dict().items()} == shapes


def test_cell_features_need_their_width_in_the_network(cfg_factory):
    cfg = cfg_factory("model.graph.cell=${simulator.cell}")
    with pytest.raises(InstantiationException, match=r"model\.net\.extra_part_features=0.*=10"):
        instantiate(cfg.model)
