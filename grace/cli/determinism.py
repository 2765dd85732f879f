"""Threads and reproducibility, set the same way in the main process and in every fold worker."""

from __future__ import annotations

import torch


def cap_threads(threads: int) -> None:
    """Use `threads` intra-op threads, with torch's deterministic kernels.

    With more than one thread, the CPU backward of reading features by index (an accumulating
    index_put) adds in a different order from run to run, so two trainings of one seed drifted
    apart at two threads; the deterministic kernels cost no measurable time here.
    `warn_only`: an accelerator op without a deterministic kernel warns instead of failing.
    """
    torch.set_num_threads(threads)
    torch.use_deterministic_algorithms(True, warn_only=True)
