"""One progress display for a cross-validated experiment, whether folds run here or in processes.

Every fold's Trainer carries a :class:`FoldReporter` (a Lightning callback) that sends its epochs,
batches and losses through a `multiprocessing.Manager` queue, which loky worker processes accept
as an argument. The parent process draws from that queue, with tqdm (Lightning's own progress
library): one bar for the folds done out of all, and under it one bar per running fold with its
epoch (of `max_epochs`), the batches of that epoch and its latest losses. When the terminal is
not interactive (a log file, CI) the bars are off and a line per finished fold is logged instead.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from multiprocessing.managers import SyncManager
from types import TracebackType
from typing import Any

import lightning.pytorch as pl
from tqdm import tqdm

from grace.cli.signals import ignore_stops

log = logging.getLogger(__name__)


class FoldReporter(pl.Callback):
    """Sends one fold's progress to the display; picklable (it holds a queue proxy)."""

    def __init__(self, queue: Any, fold: int, interval: float = 0.2) -> None:
        self.queue, self.fold, self.interval = queue, fold, interval
        self._sent = 0.0

    def _send(self, kind: str, *payload: Any) -> None:
        self.queue.put((self.fold, kind, *payload))

    def on_train_epoch_start(self, trainer: pl.Trainer, pl_module: pl.LightningModule) -> None:
        batches = trainer.num_training_batches
        self._send("epoch", trainer.current_epoch + 1, trainer.max_epochs, batches)

    def on_train_batch_end(
        self,
        trainer: pl.Trainer,
        pl_module: pl.LightningModule,
        outputs: Any,
        batch: Any,
        batch_idx: int,
    ) -> None:
        now = time.monotonic()
        if now - self._sent >= self.interval:  # a queue message costs a round trip
            self._sent = now
            self._send("batch", batch_idx + 1)

    def on_train_epoch_end(self, trainer: pl.Trainer, pl_module: pl.LightningModule) -> None:
        losses = {k: float(v) for k, v in trainer.callback_metrics.items() if k.endswith("loss")}
        self._send("losses", losses)

    def stage(self, text: str) -> None:
        """Tell the display what the fold does after training (e.g. "evaluating")."""
        self._send("stage", text)

    def done(self, train_s: float, evaluate_s: float) -> None:
        self._send("done", train_s, evaluate_s)


class _FoldBar:
    def __init__(self, fold: int, position: int) -> None:
        self.fold, self.position = fold, position
        self.epochs = 0
        self.bar = tqdm(
            position=position, leave=False, disable=None, dynamic_ncols=True, unit="batch"
        )

    def epoch(self, epoch: int, max_epochs: int, batches: int) -> None:
        self.epochs = epoch
        self.bar.reset(total=batches)
        self.bar.set_description(f"fold {self.fold} epoch {epoch}/{max_epochs}")

    def batch(self, done: int) -> None:
        self.bar.n = done
        self.bar.refresh()

    def losses(self, losses: dict[str, float]) -> None:
        """The epoch is over: a full bar and its losses."""
        self.bar.n = self.bar.total or 0
        self.bar.set_postfix({k: f"{v:.4f}" for k, v in sorted(losses.items())})

    def stage(self, text: str) -> None:
        self.bar.reset(total=None)
        self.bar.set_description(f"fold {self.fold} {text}")


class ExperimentProgress:
    """Context manager around the folds; `reporter(fold)` gives each fold its callback."""

    def __init__(self, folds: int) -> None:
        self.folds = folds
        self._manager = SyncManager()
        self._manager.start(ignore_stops)  # a signal to the process group leaves it to __exit__
        self.queue = self._manager.Queue()
        self._bars: dict[int, _FoldBar] = {}
        self._done = 0
        self._overall = tqdm(
            total=folds, desc="folds done", unit="fold", disable=None, dynamic_ncols=True
        )
        self._thread = threading.Thread(target=self._listen, daemon=True)

    def reporter(self, fold: int) -> FoldReporter:
        return FoldReporter(self.queue, fold)

    def __enter__(self) -> ExperimentProgress:
        self._thread.start()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        # The queue's server gone (killed) ends the listener too.
        with contextlib.suppress(OSError, EOFError):
            self.queue.put(None)
        self._thread.join()
        for bar in self._bars.values():
            bar.bar.close()
        self._overall.close()
        self._manager.shutdown()

    def _bar(self, fold: int) -> _FoldBar:
        if fold not in self._bars:
            taken = {bar.position for bar in self._bars.values()}
            position = next(p for p in range(1, len(taken) + 2) if p not in taken)
            self._bars[fold] = _FoldBar(fold, position)
        return self._bars[fold]

    def _next(self) -> tuple | None:
        try:
            return self.queue.get()
        except (OSError, EOFError):
            return None

    def _listen(self) -> None:
        """Draw every message until the sentinel (or the queue's server is gone); all tqdm
        calls happen in this thread."""
        while (message := self._next()) is not None:
            fold, kind, *payload = message
            if kind == "done":
                bar = self._bars.pop(fold, None)
                epochs = bar.epochs if bar is not None else 0
                if bar is not None:
                    bar.bar.close()
                self._overall.update(1)
                self._done += 1
                train_s, evaluate_s = payload
                log.info(
                    "fold %d done (%d of %d): %d epochs, trained in %.0f s, evaluated in %.0f s",
                    *(fold, self._done, self.folds, epochs, train_s, evaluate_s),
                )
            else:
                getattr(self._bar(fold), kind)(*payload)
            self._overall.refresh()  # its clock
