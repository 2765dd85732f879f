"""Where a training epoch's time goes: a Lightning profiler that folds the trainer's actions into
the stages of an epoch (docs/training.md, "Where an epoch's time goes").

Lightning times its own actions (fetching a batch, the training step, backward, the optimiser
step, validation, every hook and callback) through `trainer.profiler`; GraceModule adds its forward
pass and its loss inside the training step. :class:`StageProfiler` sums each action's wall time
and the main thread's CPU time over the epochs, counting only what runs inside an epoch, and
:meth:`StageProfiler.stages` subtracts the nested ones, so the stages add up to the epochs'
time. On a machine shared with other jobs, wall time counts the waits for the CPU while the
thread's CPU time does not; with `threads=1` (a fold's share of two cores beside another fold) the
CPU time is the work itself.
"""

from __future__ import annotations

import time
from collections import defaultdict

from lightning.pytorch.profilers import Profiler

EPOCH = "run_training_epoch"
FORWARD = "[GraceModule]train_forward"
LOSS = "[GraceModule]train_loss"
_STEP = "[Strategy]SingleDeviceStrategy.training_step"
_BACKWARD = "[Strategy]SingleDeviceStrategy.backward"
_OPTIMISER = "[LightningModule]GraceModule.optimizer_step"
_BATCH = "[_TrainingEpochLoop].train_dataloader_next"
_VALIDATION = ("[_EvaluationLoop].val_next", "[Strategy]SingleDeviceStrategy.validation_step")
_EPOCH_END = (
    "[LightningModule]GraceModule.on_train_epoch_end",
    "[LightningModule]GraceModule.on_validation_epoch_end",
)
STAGES = (
    "batch assembly",
    "forward",
    "loss",
    "step logging",
    "backward",
    "optimiser",
    "validation",
    "epoch-end metrics",
    "callbacks",
    "rest",
)
"""The stages of :meth:`StageProfiler.stages`, in the order an epoch meets them: the training
batches (collate, forward, loss, logging and the step's scores for the training AUC, backward,
optimiser = gradient clipping, Adam and zeroing), the validation batches (collate, forward, loss),
the step AUCs at the epoch's end, the callbacks (checkpoints, early stopping, progress), and the
rest of the epoch (Lightning's loop and logger, Python)."""


class StageProfiler(Profiler):
    """Sums wall and main-thread CPU seconds per Lightning action inside training epochs."""

    def __init__(self) -> None:
        super().__init__()
        self._open: dict[str, tuple[float, float]] = {}
        self.wall: dict[str, float] = defaultdict(float)
        self.cpu: dict[str, float] = defaultdict(float)
        self.epochs = 0

    def start(self, action_name: str) -> None:
        if action_name == EPOCH or EPOCH in self._open:
            self._open[action_name] = (time.perf_counter(), time.thread_time())

    def stop(self, action_name: str) -> None:
        started = self._open.pop(action_name, None)
        if started is None:
            return
        self.wall[action_name] += time.perf_counter() - started[0]
        self.cpu[action_name] += time.thread_time() - started[1]
        self.epochs += action_name == EPOCH

    def stages(self, wall: bool = False) -> dict[str, float]:
        """Seconds per epoch of each of STAGES, by the main thread's CPU clock (by the wall clock
        if `wall`); they add up to the mean epoch (validation included)."""
        t = self.wall if wall else self.cpu
        step, backward = t[_STEP], t[_BACKWARD]
        out = {
            "batch assembly": t[_BATCH],
            "forward": t[FORWARD],
            "loss": t[LOSS],
            "step logging": step - t[FORWARD] - t[LOSS],
            "backward": backward,
            "optimiser": t[_OPTIMISER] - step - backward,
            "validation": sum(t[a] for a in _VALIDATION),
            "epoch-end metrics": sum(t[a] for a in _EPOCH_END),
            "callbacks": sum(v for a, v in t.items() if a.startswith("[Callback]")),
        }
        out["rest"] = t[EPOCH] - sum(out.values())
        return {k: v / max(self.epochs, 1) for k, v in out.items()}

    def summary(self) -> str:
        cpu, wall = self.stages(), self.stages(wall=True)
        lines = [f"{'stage':<20} {'CPU s/epoch':>12} {'wall s/epoch':>13}"]
        lines += [f"{k:<20} {cpu[k]:>12.3f} {wall[k]:>13.3f}" for k in STAGES]
        lines.append(f"{'epoch':<20} {sum(cpu.values()):>12.3f} {sum(wall.values()):>13.3f}")
        return "\n".join(lines)
