"""Kill/resume of `python -m grace scale=smoke`: a run stopped at a random point (SIGTERM, after
some checkpoints exist) and rerun with the same command ends with the results.json metrics of an
uninterrupted run. The fast test of the resume logic is tests/cli/test_fit_resume.py."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}  # this checkout's grace, from any folder


def _command(tmp_path: Path, out: str) -> list[str]:
    return [
        *(sys.executable, "-m", "grace", "scale=smoke", "protocol.folds=2"),
        *("trainer.max_epochs=12", "trainer.enable_progress_bar=false"),
        "logger.csv.flush_logs_every_n_steps=1",  # the test watches the epochs in metrics.csv
        f"paths.data_dir={tmp_path / 'data'}",
        f"paths.output_dir={tmp_path / out}",
    ]


def _checkpointed(run: Path) -> bool:
    return bool(list(run.glob("fold_*/checkpoints/last.ckpt")))


def _epochs(run: Path) -> int:
    """Most validated epochs of any fold so far (Lightning's CSV log)."""
    counts = [
        sum(1 for line in path.read_text().splitlines()[1:] if line.split(",")[-2:] != ["", ""])
        for path in run.glob("fold_*/logs/*/metrics.csv")
    ]
    return max(counts, default=0)


def _metrics(folder: Path) -> dict:
    results = json.loads((folder / "results.json").read_text())
    return {key: results[key] for key in ("per_size", "baselines", "collapsed_folds")}


@pytest.mark.slow
def test_a_killed_experiment_resumes_to_the_same_metrics(tmp_path):
    subprocess.run(_command(tmp_path, "whole"), cwd=tmp_path, env=ENV, check=True)
    log = (tmp_path / "killed.txt").open("w")
    killed = subprocess.Popen(
        _command(tmp_path, "killed"), cwd=tmp_path, env=ENV, stdout=log, stderr=log
    )
    # A random point of the training: after epoch k (1..6 of 12) of some fold, with a last.ckpt.
    # Waiting for an epoch, not for a time, keeps the kill inside training on a fast or a loaded
    # machine alike (a fixed delay could land after results.json, in the recording).
    k = int(np.random.default_rng().integers(1, 7))
    while not (_checkpointed(tmp_path / "killed") and _epochs(tmp_path / "killed") >= k):
        assert killed.poll() is None, (tmp_path / "killed.txt").read_text()
        time.sleep(0.05)
    killed.send_signal(signal.SIGTERM)
    assert killed.wait(timeout=60) != 0
    assert not (tmp_path / "killed" / "results.json").exists()
    subprocess.run(_command(tmp_path, "killed"), cwd=tmp_path, env=ENV, check=True)
    assert _metrics(tmp_path / "killed") == _metrics(tmp_path / "whole")
