"""Checkpoints this project writes, and the models rebuilt from them (task=plan).

A training run keeps its resolved config in its folder beside `checkpoints/`
(grace/model/kept.py), so a model is rebuilt from that config and the checkpoint's weights must
fit it exactly: a checkpoint made for another config stops with one line naming both files.

A model rebuilt to plan is a :class:`KeptModel`, not the LightningModule it was trained as: what
scoring reads of it (network, graph encoding, implementation, seed), without the training
objective. So planning loads neither Lightning nor, on the fast path, PyG: both take seconds to
import, longer than planning an assembly.
"""

from __future__ import annotations

from pathlib import Path

import torch
from hydra.utils import instantiate
from omegaconf import DictConfig

from grace.errors import UserError
from grace.graphs.encoding import GraphEncoding
from grace.model.grace_pyg import GraceNet, Layers, Score
from grace.model.impls import NetImpl
from grace.model.kept import kept_config


def checkpoint_weights(path: str | Path) -> dict:
    """The module weights of a Lightning checkpoint this project wrote (a full pickle, which
    Lightning needs for the objects it stores: our own files are trusted)."""
    return torch.load(path, map_location="cpu", weights_only=False)["state_dict"]


class KeptModel(torch.nn.Module):
    """A trained GRACE network as scoring uses it: what it reads of a GraceModule (`net`, the
    graph encoding `enc`, the implementation `impl`, the `seed` of randomised encodings)."""

    def __init__(
        self, net: GraceNet, graph: GraphEncoding, impl: NetImpl, seed: int, name: str
    ) -> None:
        super().__init__()
        self.net, self.enc, self.impl, self.seed, self.name = net, graph, impl, seed, name

    @property
    def device(self) -> torch.device:
        return next(self.net.parameters()).device

    @property
    def dtype(self) -> torch.dtype:
        """The weights' dtype, as LightningModule.dtype gives it, so scoring reads either."""
        return next(self.net.parameters()).dtype


def load_model(ckpt: Path, layers: Layers | None = None) -> tuple[KeptModel, DictConfig]:
    """The model rebuilt from the config kept beside `ckpt`, with the checkpoint's weights.

    Its network is built from `layers`, by default those its implementation runs on
    (`impl.loaded_layers()`: PyG's for the reference path, plain parameter holders for the fast
    path); pass grace_pyg.pyg_layers() to run PyG's modules on it as well."""
    kept, cfg = kept_config(ckpt)
    if "score" not in cfg.model.net:  # kept before the score was a key: those runs planned
        cfg.model.net.score = Score.geometric.value  # with the geometric mean
    try:
        state = checkpoint_weights(ckpt)
    except Exception as e:
        raise UserError(
            f"ckpt={ckpt}: not a readable Lightning checkpoint ({type(e).__name__}: {e}); "
            "fix: pass the best.ckpt a train or experiment run wrote"
        ) from None
    impl = instantiate(cfg.model.impl)
    with torch.device("meta"):  # no initialisation: the checkpoint's weights replace it
        net = GraceNet(instantiate(cfg.model.net), layers or impl.loaded_layers())
    graph = instantiate(cfg.model.graph)
    module = KeptModel(net, graph, impl, int(cfg.model.seed), str(cfg.model.name))
    try:
        module.load_state_dict(state, strict=True, assign=True)
    except RuntimeError as e:
        first = str(e).splitlines()[1].strip() if len(str(e).splitlines()) > 1 else str(e)
        raise UserError(
            f"ckpt={ckpt} was made for another config than {kept} ({first}); fix: keep the "
            "checkpoint beside the config.yaml of the run that trained it"
        ) from None
    return module.eval(), cfg
