"""N `task=tune` processes started together on one new SQLite study: is every trial recorded?

    PYTHONPATH=. python tests/tasks/tune_race.py 3 10    # 3 processes, 10 tries

Each process loads grace and composes its config first (puzzles and the closed-form trainer of
tune_fakes: no simulator, no network), then waits at a barrier of files until all are ready,
so that all reach the new database within a millisecond or so of each other, as processes
started together on an idle machine do. Prints one line per try and the count of tries in which
every process ended well and the study holds every trial of every process.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TASKS = Path(__file__).resolve().parent
ROOT = TASKS.parents[1]
TRIALS = 2
"""Trials per process."""
OVERRIDES = (
    "task=tune",
    "~dataset",
    "+dataset={_target_: experiment_fakes.PuzzleSource, seed: 0}",
    "task.fit._target_=tune_fakes.fit",
    *("threads=1", "trainer.max_epochs=3", "tune.folds=1", "tune.pruner=null"),
    f"tune.n_trials={TRIALS}",
)


def worker(folder: Path, index: int, processes: int) -> None:
    """One tune process: compose, wait for the others, run."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from omegaconf import open_dict

    from grace import CONF_DIR
    from grace.cli.schemas import register_schemas
    from grace.tasks.tune import run

    register_schemas()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        out = folder / f"process_{index}"
        cfg = compose(
            config_name="config",
            overrides=[
                *OVERRIDES,
                f"tune.storage=sqlite:///{folder / 'study.db'}",
                f"paths.output_dir={out}",
            ],
        )
    with open_dict(cfg):
        cfg.paths.log_file = str(out / "grace.log")
    (folder / f"ready_{index}").touch()
    while len(list(folder.glob("ready_*"))) < processes:
        time.sleep(0.001)
    run(cfg)


def attempt(processes: int) -> tuple[bool, str]:
    """Start `processes` workers on a new study; whether every trial was recorded, and how."""
    import optuna

    folder = Path(tempfile.mkdtemp(prefix="tune_race_"))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(TASKS), str(ROOT)])}
    command = [sys.executable, __file__, "--worker", str(folder), str(processes)]
    runs = [
        subprocess.Popen([*command, str(i)], env=env, stderr=subprocess.PIPE, text=True)
        for i in range(processes)
    ]
    errors = [run.communicate(timeout=600)[1] for run in runs]
    codes = [run.returncode for run in runs]
    url = f"sqlite:///{folder / 'study.db'}"
    try:
        trials = optuna.load_study(study_name="grace", storage=url).trials
    except KeyError:  # no process got as far as creating the study
        trials = []
    complete = sum(t.state.name == "COMPLETE" for t in trials)
    failed = [e.strip().splitlines()[-1] for e, c in zip(errors, codes, strict=True) if c]
    ok = complete == processes * TRIALS and not failed
    shutil.rmtree(folder)
    return ok, f"exit codes {codes}, {complete} of {processes * TRIALS} trials {failed}"


def main(processes: int, tries: int) -> None:
    good = 0
    for n in range(tries):
        ok, how = attempt(processes)
        good += ok
        print(f"try {n + 1}: {how}", flush=True)
    print(f"{processes} processes: every trial recorded in {good} of {tries} tries")


if __name__ == "__main__":
    if sys.argv[1] == "--worker":
        worker(Path(sys.argv[2]), int(sys.argv[4]), int(sys.argv[3]))
    else:
        main(int(sys.argv[1]), int(sys.argv[2]))
