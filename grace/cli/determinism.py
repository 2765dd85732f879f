"""Threads and reproducibility, set the same way in the main process and in every fold worker."""

from __future__ import annotations

import os
import random
import sys

import numpy as np
import torch


def seed_all(seed: int) -> None:
    """Seed Python's, numpy's and torch's generators with `seed`, as Lightning's
    `seed_everything(seed, workers=True)` does, down to the environment it leaves for its
    Trainer (PL_GLOBAL_SEED, and PL_SEED_WORKERS: each data-loader worker seeded apart). Here
    because Lightning takes seconds to import, and a task that trains nothing (task=plan) should
    not wait for it."""
    os.environ["PL_GLOBAL_SEED"] = str(seed)
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
    os.environ["PL_SEED_WORKERS"] = "1"


def cap_threads(threads: int) -> None:
    """Use `threads` intra-op threads, with torch's deterministic kernels.

    With more than one thread, the CPU backward of reading features by index (an accumulating
    index_put) adds in a different order from run to run, so two trainings of one seed drifted
    apart at two threads; the deterministic kernels cost no measurable time here.
    `warn_only`: an accelerator op without a deterministic kernel warns instead of failing.
    """
    torch.set_num_threads(threads)
    if "torch._inductor.config" in sys.modules:
        torch.use_deterministic_algorithms(True, warn_only=True)
        return
    # What that call does, without the import of torch.compile's stack it starts (seconds, for
    # one flag): the kernels' switch, and inductor's deterministic mode through the variable
    # its config reads when (if ever: model/impl=compiled) it is imported.
    os.environ["TORCHINDUCTOR_DETERMINISTIC"] = "1"
    torch._C._set_deterministic_algorithms(True, warn_only=True)
