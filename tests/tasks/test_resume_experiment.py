"""Kill/resume of `python -m grace scale=smoke`: a run stopped at a random point (SIGTERM, after
some checkpoints exist) and rerun with the same command ends with the results.json metrics of an
uninterrupted run (issue 13). The fast test of the resume logic is tests/model/test_resume.py."""

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
        f"paths.data_dir={tmp_path / 'data'}",
        f"paths.output_dir={tmp_path / out}",
    ]


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
    while not list((tmp_path / "killed").glob("fold_*/checkpoints/last.ckpt")):
        assert killed.poll() is None, (tmp_path / "killed.txt").read_text()
        time.sleep(0.2)
    time.sleep(np.random.default_rng().uniform(0, 3))  # a random point of the training
    killed.send_signal(signal.SIGTERM)
    assert killed.wait(timeout=60) != 0
    assert not (tmp_path / "killed" / "results.json").exists()
    subprocess.run(_command(tmp_path, "killed"), cwd=tmp_path, env=ENV, check=True)
    assert _metrics(tmp_path / "killed") == _metrics(tmp_path / "whole")
