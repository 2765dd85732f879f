"""Sweeps through Hydra launchers: a run's results do not depend on where it runs.

`hydra/launcher=submitit_local` goes through the same launcher code as `hydra/launcher=slurm`
(submitit pickles each run, a separate process unpickles and runs it); only the executor that
starts the process differs. The slow SLURM test starts a single-node cluster on this machine
(.ci/slurm-setup.sh, as root) and runs a sweep through `hydra/launcher=slurm` for real.
"""

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra

from grace import CONF_DIR
from grace.cli.schemas import register_schemas

ROOT = Path(__file__).resolve().parents[2]
SLURM_SETUP = ROOT / ".ci" / "slurm-setup.sh"
SLURM_DAEMONS = {
    "slurmctld": "/run/slurmctld.pid",
    "slurmd": "/run/slurmd.pid",
    "munged": "/run/munge/munged.pid",
}


def sweep(tmp_path: Path, name: str, launcher: str, *overrides: str) -> list[dict]:
    """Run `python -m grace -m` over seed=0,1 with `launcher`; each job's result file, by job."""
    out = tmp_path / name
    subprocess.run(
        [
            *(sys.executable, "-m", "grace", "-m", f"hydra/launcher={launcher}", "seed=0,1"),
            *overrides,
            f"hydra.sweep.dir={out}",
            f"paths.data_dir={tmp_path / 'data'}",
        ],
        cwd=ROOT,
        check=True,
        capture_output=True,
        timeout=600,
    )
    # the one result file of a job: metrics.json (task=train) or results.json (experiment)
    jobs = sorted(
        (p for p in out.glob("*/*.json") if p.name in ("metrics.json", "results.json")),
        key=lambda p: int(p.parent.name),
    )
    return [json.loads(p.read_text()) for p in jobs]


TRAIN = (
    "task=train",
    "dataset.sizes={3: 6, 4: 6}",
    "trainer.max_epochs=2",
    "threads=1",  # one thread: bitwise the same arithmetic in every process
)


@pytest.mark.slow  # half a minute of job processes; the experiment's sweep below also runs it
def test_submitit_local_runs_a_two_job_sweep_like_the_basic_launcher(tmp_path):
    local = sweep(tmp_path, "submitit", "submitit_local", *TRAIN)
    basic = sweep(tmp_path, "basic", "basic", *TRAIN)
    assert len(local) == len(basic) == 2
    for a, b in zip(local, basic, strict=True):
        assert a["step_auc"] == b["step_auc"] and a["assemblies"] == b["assemblies"]
    assert local[0]["step_auc"] != local[1]["step_auc"]  # two seeds, two different runs


SMOKE = ("scale=smoke", "protocol.folds=2", "trainer.max_epochs=3")


@pytest.fixture(scope="module")
def basic_smoke_sweep(tmp_path_factory) -> tuple[Path, list[dict]]:
    """The experiment's two-run sweep under the basic launcher, which the other launchers'
    sweeps (in the same folder, sharing its data set) must reproduce."""
    folder = tmp_path_factory.mktemp("sweeps")
    return folder, sweep(folder, "basic", "basic", *SMOKE)


@pytest.mark.slow
def test_the_experiment_gives_the_same_metrics_under_every_local_launcher(basic_smoke_sweep):
    folder, basic = basic_smoke_sweep
    for launcher in ("joblib", "submitit_local"):
        runs = sweep(folder, launcher, launcher, *SMOKE)
        for a, b in zip(basic, runs, strict=True):
            assert a["per_size"] == b["per_size"] and a["baselines"] == b["baselines"]
    assert [r["run"]["seed"] for r in basic] == [0, 1]


def test_the_slurm_launcher_config_composes():
    register_schemas()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(
            config_name="config",
            overrides=["hydra/launcher=slurm", "threads=4"],
            return_hydra_config=True,
        )
    launcher = cfg.hydra.launcher
    assert launcher._target_.endswith("submitit_launcher.SlurmLauncher")
    assert launcher.cpus_per_task == 4 and launcher.timeout_min == 240
    assert launcher.tasks_per_node == 1 and launcher.nodes == 1


def _running(name: str) -> bool:
    return subprocess.run(["pgrep", "-x", name], capture_output=True).returncode == 0


def _wait_for_an_empty_queue(timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        queue = subprocess.run(["squeue", "-h"], capture_output=True, text=True)
        if queue.returncode != 0 or not queue.stdout.strip():
            return
        time.sleep(1.0)


@pytest.fixture
def slurm_cluster():
    """A single-node SLURM cluster on this machine (.ci/slurm-setup.sh); the daemons this
    fixture started are stopped afterwards. Skips, saying why, where it cannot run."""
    if os.geteuid() != 0:
        pytest.skip("a single-node SLURM needs root to install and start its daemons")
    started = [name for name in SLURM_DAEMONS if not _running(name)]
    setup = subprocess.run([str(SLURM_SETUP)], capture_output=True, text=True, timeout=600)
    if setup.returncode != 0:
        pytest.skip(f"no single-node SLURM here: {setup.stderr.strip() or setup.stdout.strip()}")
    yield setup.stdout.strip()
    if started:  # let the jobs' steps end first, or their srun clients outlive the daemons
        _wait_for_an_empty_queue(timeout=120.0)
    for name in started:  # by the pid each daemon wrote, never by name
        with contextlib.suppress(FileNotFoundError, ProcessLookupError, ValueError):
            os.kill(int(Path(SLURM_DAEMONS[name]).read_text().strip()), signal.SIGTERM)


@pytest.mark.slow
def test_a_two_job_sweep_on_slurm_gives_the_basic_launchers_metrics(
    basic_smoke_sweep, slurm_cluster
):
    assert shutil.which("sbatch")
    folder, basic = basic_smoke_sweep
    small = ("hydra.launcher.cpus_per_task=1", "hydra.launcher.mem_gb=2")  # both jobs at once
    slurm = sweep(folder, "slurm", "slurm", *SMOKE, *small)
    assert len(slurm) == len(basic) == 2
    for a, b in zip(slurm, basic, strict=True):
        assert a["per_size"] == b["per_size"] and a["baselines"] == b["baselines"]
    assert [r["run"]["seed"] for r in slurm] == [0, 1]
    logs = list((folder / "slurm" / ".submitit").glob("*/*_log.out"))
    assert len(logs) == 2  # each run was a SLURM job (submitit keeps a log per job)
