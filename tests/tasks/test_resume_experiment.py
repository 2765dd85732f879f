"""Kill/resume of `python -m grace scale=smoke`: a run stopped by SIGTERM at random points and
rerun each time with the same command ends with the results.json of an uninterrupted run, every
number but the timings. The fast test of the resume logic is tests/cli/test_fit_resume.py.

The run is killed five times, each at a random moment after its (re)start has finished an epoch,
so the kills land anywhere in training and evaluation: in an epoch, a validation, a checkpoint
write, between two folds. With the default patience the lr scheduler and early stopping decide
in every fold, which a shorter run (a dozen epochs, as this test once ran) never reaches.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}  # this checkout's grace, from any folder
KILLS = 5
TIMINGS = ("seconds", "seconds_by_stage")


def _command(tmp_path: Path, out: str) -> list[str]:
    return [
        *(sys.executable, "-m", "grace", "scale=smoke", "trainer.enable_progress_bar=false"),
        f"paths.data_dir={tmp_path / 'data'}",
        f"paths.output_dir={tmp_path / out}",
    ]


def _epochs(run: Path) -> dict[str, int]:
    """Per fold, the epoch its last checkpoint resumes at (grace/model/resume.py)."""
    return {
        path.parents[1].name: int(torch.load(path, weights_only=False)["epoch"])
        for path in sorted(run.glob("fold_*/checkpoints/last.ckpt"))
    }


def _results(folder: Path) -> dict:
    """results.json without its timings and without the command line (paths differ)."""
    results = json.loads((folder / "results.json").read_text())
    results["run"].pop("overrides")
    return {k: v for k, v in results.items() if k not in TIMINGS}


def _checkpointed_since(run: Path, since: float) -> bool:
    """Whether a fold wrote its last checkpoint (an epoch ended) after `since` (a wall time)."""
    return any(p.stat().st_mtime > since for p in run.glob("fold_*/checkpoints/last.ckpt"))


@pytest.mark.slow
def test_a_run_killed_at_random_points_resumes_to_the_same_results(tmp_path):
    start = time.perf_counter()
    subprocess.run(_command(tmp_path, "whole"), cwd=tmp_path, env=ENV, check=True)
    whole_s = time.perf_counter() - start
    rng = np.random.default_rng()
    landed = []
    for kill in range(KILLS):
        log = (tmp_path / f"killed_{kill}.txt").open("w")
        started = time.time()
        run = subprocess.Popen(
            _command(tmp_path, "killed"), cwd=tmp_path, env=ENV, stdout=log, stderr=log
        )
        # Once this (re)start has finished an epoch, a random delay: the kill lands anywhere in
        # training or evaluation (a start-up alone takes a while, and a kill in it saves nothing).
        while run.poll() is None and not _checkpointed_since(tmp_path / "killed", started):
            time.sleep(0.2)
        delay = float(rng.uniform(0.0, 0.25 * whole_s))
        try:
            code = run.wait(timeout=delay)
        except subprocess.TimeoutExpired:
            run.send_signal(signal.SIGTERM)
            code = run.wait(timeout=120)
        landed.append((round(time.time() - started, 1), code, _epochs(tmp_path / "killed")))
        if code == 0 or (tmp_path / "killed" / "results.json").exists():
            break  # the run ended before its kill, or the kill came after its last write
    print(f"uninterrupted run {whole_s:.0f} s; kills (s after start, exit code, epoch each fold "
          f"resumes at): {landed}")  # fmt: skip
    subprocess.run(_command(tmp_path, "killed"), cwd=tmp_path, env=ENV, check=True)
    assert _results(tmp_path / "killed") == _results(tmp_path / "whole")
