"""GRACE as a LightningModule: loss, optimiser and validation step-AUC of SPEC §5 / §7."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import lightning.pytorch as pl
import numpy as np
import torch

from grace.evaluation.metrics import step_auc
from grace.graphs.datamodule import IMPLS, StateBatch
from grace.graphs.dense import DenseAssemblies
from grace.graphs.encoding import GraphEncoding
from grace.model.grace_fast import fast_logits
from grace.model.grace_pyg import GraceNet, NetConfig
from grace.model.loss import grace_loss


def net_config(model: Mapping[str, Any]) -> NetConfig:
    """Network shape from the `model` config group."""
    return NetConfig(
        hidden=int(model["hidden"]),
        surface_blocks=int(model["surface_blocks"]),
        negative_slope=float(model["negative_slope"]),
        pe_dim=int(model["graph"]["pe_dim"]),
        state_blocks=int(model.get("state_blocks", 0)),
        pair_readout=int(model.get("pair_readout", 0)),
        readout_rounds=int(model.get("readout_rounds", 1)),
    )


def graph_encoding(model: Mapping[str, Any]) -> GraphEncoding:
    """Assembly Graph encoding (PE kind, permutations, distance scale) from `model.graph`."""
    return GraphEncoding(**dict(model["graph"]))


class GraceModule(pl.LightningModule):
    """The GRACE network with its training objective; `impl` picks the fast or PyG path.

    `model` is the plain dict of the `model` config group (stored in the checkpoint).
    """

    def __init__(
        self,
        model: dict[str, Any],
        lr: float = 0.0022,
        seed: int = 0,
        lr_decay: dict[str, Any] | None = None,
    ) -> None:
        super().__init__()
        self.save_hyperparameters()
        if model["impl"] not in IMPLS:
            raise ValueError(f"model.impl={model['impl']!r}: use one of {IMPLS}")
        self.net = GraceNet(net_config(model))
        self.enc = graph_encoding(model)
        self.impl: str = model["impl"]
        self.delta = float(model["delta"])
        self.lr = lr
        self.seed = seed
        self.lr_decay = lr_decay
        # What the lr decay watches; fit() sets them to the early-stopping monitor.
        self.monitor, self.monitor_mode = "val_loss", "min"
        self._outputs: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {"train": [], "val": []}

    def forward(self, batch: StateBatch) -> torch.Tensor:
        """Part logits (T, N) of the batch's states; padding entries are meaningless."""
        if isinstance(batch.inputs, DenseAssemblies):
            return fast_logits(self.net, batch.inputs, batch.state_assembly, batch.flags)
        flat = self.net(batch.inputs)
        out = flat.new_zeros(batch.mask.shape)
        out[batch.mask] = flat
        return out

    def _step(self, batch: StateBatch, stage: str) -> torch.Tensor:
        logits = self(batch)
        loss = grace_loss(logits, batch.labels, batch.flags, batch.mask, self.delta)
        self.log(f"{stage}_loss", loss, on_epoch=True, on_step=False, batch_size=batch.n_states)
        scores = torch.sigmoid(logits.detach())[batch.mask].numpy()
        self._outputs[stage].append((scores, batch.labels[batch.mask].numpy()))
        return loss

    def training_step(self, batch: StateBatch, batch_idx: int) -> torch.Tensor:
        return self._step(batch, "train")

    def validation_step(self, batch: StateBatch, batch_idx: int) -> None:
        self._step(batch, "val")

    def _log_auc(self, stage: str) -> None:
        outputs = self._outputs[stage]
        if outputs:
            scores, labels = (np.concatenate(x) for x in zip(*outputs, strict=True))
            self.log(f"{stage}_step_auc", step_auc(scores, labels))
        outputs.clear()

    def on_train_epoch_end(self) -> None:
        self._log_auc("train")

    def on_validation_epoch_end(self) -> None:
        self._log_auc("val")

    def configure_optimizers(self) -> Any:
        """Adam at the paper's lr; with `lr_decay` (not in SPEC §5) the lr is multiplied by
        `factor` whenever the monitored loss has not improved for `patience` epochs."""
        optimiser = torch.optim.Adam(self.parameters(), lr=self.lr)
        if not self.lr_decay:
            return optimiser
        decay = torch.optim.lr_scheduler.ReduceLROnPlateau(
            optimiser,
            mode=self.monitor_mode,
            factor=float(self.lr_decay["factor"]),
            patience=int(self.lr_decay["patience"]),
        )
        return {
            "optimizer": optimiser,
            "lr_scheduler": {"scheduler": decay, "monitor": self.monitor},
        }
