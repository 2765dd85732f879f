"""GRACE as a LightningModule: loss, optimiser and the logged step AUC (docs/training.md).

Built by `hydra.utils.instantiate(cfg.model)`: the `model` config group gives the network shape
(`net`), the Assembly Graph encoding (`graph`), the implementation (`impl`), the loss weight and
the optimiser and lr scheduler as partials. Every argument is stored in the checkpoint, so
`GraceModule.load_from_checkpoint(path, weights_only=False)` rebuilds the module without the
config (the arguments are objects, hence `weights_only=False`: load only checkpoints you trust).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

import lightning.pytorch as pl
import torch
from lightning.pytorch.profilers import PassThroughProfiler
from torchmetrics.functional.classification import binary_precision_recall_curve
from torchmetrics.utilities.compute import auc

from grace.errors import UserError
from grace.graphs.batches import StateBatch
from grace.graphs.encoding import GraphEncoding
from grace.model.grace_pyg import GraceNet, NetConfig
from grace.model.impls import NetImpl
from grace.model.loss import grace_loss

Optimizer = Callable[[Iterable[torch.nn.Parameter]], torch.optim.Optimizer]
"""The optimiser without its parameters (a `_partial_` config)."""

Scheduler = Callable[[torch.optim.Optimizer], Any]
"""The lr scheduler without its optimiser (a `_partial_` config)."""

StepLoss = Callable[..., torch.Tensor]
"""`loss(logits, labels, flags, mask, delta, weights)` of the next-step output (`model/loss=`):
None is the paper's (grace_loss), `model/loss=listwise` adds a ranking term (ListwiseLoss)."""


def step_auc(scores: torch.Tensor, labels: torch.Tensor) -> torch.Tensor | None:
    """Step AUC (docs/metrics.md): area under the precision–recall curve of part scores against
    next-step labels; None without a positive label. Only target 1 (a valid next part) is
    positive: graded dead-end targets (`datamodule.dead_end_target` < 0.5) count as negatives.
    torchmetrics computes it the way evaluation does with scikit-learn, so the model needs no
    evaluation code."""
    positive = labels > 0.5
    if not positive.any():
        return None
    precision, recall, _ = binary_precision_recall_curve(scores, positive.long())
    return auc(recall, precision)


class GraceModule(pl.LightningModule):
    """The GRACE network with its training objective.

    `monitor` is the logged metric the lr scheduler watches (early stopping watches the same one:
    both follow the config's `monitor`). `seed` seeds randomised evaluation encodings (scoring.py).
    `name` is the model variant, recorded with the results.
    """

    def __init__(
        self,
        net: NetConfig,
        graph: GraphEncoding,
        impl: NetImpl,
        optimizer: Optimizer,
        scheduler: Scheduler | None = None,
        delta: float = 0.3,
        placeable_pos_weight: float = 1.0,
        loss: StepLoss | None = None,
        monitor: str = "val_loss",
        seed: int = 0,
        name: str = "grace",
    ) -> None:
        super().__init__()
        self.save_hyperparameters(logger=False)
        if net.extra_part_features != graph.extra_part_features:
            raise UserError(
                f"model.net.extra_part_features={net.extra_part_features}: the graph encoding "
                f"gives part nodes {graph.extra_part_features} more features; fix: "
                f"model.net.extra_part_features={graph.extra_part_features} (model=cell_oracle "
                "sets both)"
            )
        self.net = GraceNet(net)
        self.enc = graph
        self.impl = impl
        self.delta = delta
        self.placeable_pos_weight = placeable_pos_weight
        self.step_loss = grace_loss if loss is None else loss
        self.seed = seed
        self.name = name
        self._outputs: dict[str, list[tuple[torch.Tensor, torch.Tensor]]] = {"train": [], "val": []}

    def forward(self, batch: StateBatch) -> torch.Tensor:
        """Part logits (T, N) of the batch's states, (T, N, 2) with the placeable head; padding
        entries are meaningless."""
        return self.impl.logits(self.net, batch)

    def loss(self, batch: StateBatch, logits: torch.Tensor) -> torch.Tensor:
        """The training loss of a batch's logits (paper Eq. 4, or the `loss` given, on the
        next-step output; with the placeable head, plus the paper's loss of the second output on
        the placeable labels)."""
        two = self.net.cfg.placeable_head
        step = logits[..., 0] if two else logits
        loss = self.step_loss(
            step, batch.labels, batch.flags, batch.mask, self.delta, batch.weights
        )
        if two:  # the placeable output learns physics in every state: no dead-end or step weights
            loss = loss + grace_loss(
                logits[..., 1],
                batch.placeable,
                batch.flags,
                batch.mask,
                self.delta,
                pos_weight=self.placeable_pos_weight,
            )
        return loss

    def _step(self, batch: StateBatch, stage: str) -> torch.Tensor:
        # Regions of the trainer's profiler (a no-op unless one is set: grace/model/profiling.py;
        # none outside a Trainer, e.g. a step called by hand).
        profile = (self._trainer.profiler if self._trainer else PassThroughProfiler()).profile
        with profile(f"[GraceModule]{stage}_forward"):
            logits = self(batch)
        with profile(f"[GraceModule]{stage}_loss"):
            loss = self.loss(batch, logits)
        self.log(f"{stage}_loss", loss, on_epoch=True, on_step=False, batch_size=batch.n_states)
        scores = self.net.scores(logits.detach())[batch.mask]
        self._outputs[stage].append((scores, batch.labels[batch.mask]))
        return loss

    def training_step(self, batch: StateBatch, batch_idx: int) -> torch.Tensor:
        return self._step(batch, "train")

    def validation_step(self, batch: StateBatch, batch_idx: int) -> None:
        self._step(batch, "val")

    def _log_auc(self, stage: str) -> None:
        outputs = self._outputs[stage]
        if outputs:
            value = step_auc(*(torch.cat(x) for x in zip(*outputs, strict=True)))
            if value is not None:
                self.log(f"{stage}_step_auc", value)
        outputs.clear()

    def on_train_epoch_end(self) -> None:
        self._log_auc("train")

    def on_validation_epoch_end(self) -> None:
        self._log_auc("val")

    def configure_optimizers(self) -> Any:
        """The configured optimiser and lr schedule (not in the paper; the default a cosine over
        the run's epochs, model/scheduler=plateau halves the lr on a plateau of `monitor`)."""
        optimizer = self.hparams.optimizer(self.parameters())
        if self.hparams.scheduler is None:
            return optimizer
        scheduler = self.hparams.scheduler(optimizer)
        return {
            "optimizer": optimizer,
            "lr_scheduler": {"scheduler": scheduler, "monitor": self.hparams.monitor},
        }
