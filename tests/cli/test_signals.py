"""SIGTERM to the main process or to its whole process group (what `timeout`, `scancel` and
`kill -- -<pgid>` send) ends a run with one line and exit 130, never a traceback of the fold
workers or of the progress display (grace/cli/signals.py), whatever phase it lands in."""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from omegaconf.errors import ConfigKeyError

from grace.cli import preflight, signals
from grace.cli.preflight import EXIT_USER_ERROR, user_errors
from grace.cli.signals import held_while_loading, sigterm_as_interrupt

ROOT = Path(__file__).resolve().parents[2]
PUZZLES = "+dataset={_target_: experiment_fakes.PuzzleSource, seed: 0}"  # no simulator


def start(out: Path) -> subprocess.Popen:
    """An experiment on precedence puzzles (tests/tasks/experiment_fakes.py), two folds in two
    worker processes, trained until stopped; its own process group."""
    command = [
        *(sys.executable, "-m", "grace", "~dataset", PUZZLES, "protocol.folds=2"),
        *("task.fold_jobs=2", "threads=2", "model.net.hidden=8", "trainer.max_epochs=1000"),
        *("callbacks.early_stopping.patience=1000", f"paths.output_dir={out}"),
    ]
    env = {**os.environ, "PYTHONPATH": f"{ROOT}:{ROOT / 'tests' / 'tasks'}"}
    return subprocess.Popen(
        command, env=env, text=True, start_new_session=True, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )  # fmt: skip


def stop(run: subprocess.Popen, group: bool) -> tuple[int, str]:
    if group:
        os.killpg(run.pid, signal.SIGTERM)
    else:
        run.send_signal(signal.SIGTERM)
    out, err = run.communicate(timeout=180)
    return run.returncode, out + err


@pytest.mark.parametrize(
    "delay",
    [0.5, pytest.param(2.0, marks=pytest.mark.slow), pytest.param(4.0, marks=pytest.mark.slow)],
)
def test_sigterm_to_the_group_early_is_a_clean_stop(tmp_path, delay):
    """Early: in the imports (Python's own SIGTERM: 143, silent), the preflight, Hydra's
    composition or the task's start; which one depends on the machine's speed."""
    run = start(tmp_path / "run")
    time.sleep(delay)
    code, output = stop(run, group=True)
    assert code in (130, -signal.SIGTERM), output
    assert "Traceback" not in output and "Error" not in output, output
    assert len([line for line in output.splitlines() if "interrupted" in line]) <= 1, output


@pytest.mark.slow
@pytest.mark.parametrize("group", [True, False], ids=["group", "main process"])
def test_sigterm_in_training_is_one_line_and_exit_130(tmp_path, group):
    out = tmp_path / "run"
    run = start(out)
    deadline = time.monotonic() + 300
    while not list(out.glob("fold_*/checkpoints/last.ckpt")) and time.monotonic() < deadline:
        assert run.poll() is None, run.communicate()
        time.sleep(0.2)
    code, output = stop(run, group)
    lines = [line for line in output.splitlines() if not line.startswith("[")]  # log records
    assert code == 130, output
    assert lines == [
        f"grace: interrupted; to resume: the same command with paths.output_dir={out}"
    ], output


@pytest.mark.parametrize("ending", ["exit_interrupted(stop, sys.stderr)", "sys.exit(130)"])
def test_a_stop_caught_in_code_from_source_text_exits_130(tmp_path, ending):
    """A stop landing in `exec`/`eval`'d text (a namedtuple or dataclass an import defines) is
    marked unhandled in CPython even once caught: a plain sys.exit(130) then dies by SIGINT;
    exit_interrupted clears the mark and exits 130."""
    script = "\n".join([
        "import signal, sys",
        "from grace.cli.signals import exit_interrupted, sigterm_as_interrupt",
        "sigterm_as_interrupt()",
        "try:",
        "    exec('import signal; signal.raise_signal(signal.SIGTERM)')",
        "except KeyboardInterrupt as stop:",
        "    stop = 'grace: stopped'",
        f"    {ending}",
    ])  # fmt: skip
    (tmp_path / "stop_probe.py").write_text(script)
    env = {**os.environ, "PYTHONPATH": f"{ROOT}:{tmp_path}"}
    command = [sys.executable, "-m", "stop_probe"]  # as `python -m grace` runs
    run = subprocess.run(command, env=env, capture_output=True, text=True)
    expected = 130 if ending.startswith("exit_interrupted") else -signal.SIGINT
    assert run.returncode == expected, run.stderr


def test_a_stop_while_libraries_load_arrives_after_them(monkeypatch):
    """A SIGTERM inside the block is held (an import interrupted midway can fail as an
    ImportError or be swallowed by the extension) and raised once the block ends, also when
    another thread is there to receive it (torch starts threads; the kernel hands a process's
    signal to any thread that does not block it)."""
    monkeypatch.setattr(signals, "_received", [])  # this process's own record of stops
    before = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    release = threading.Event()
    other = threading.Thread(target=release.wait)
    other.start()
    sigterm_as_interrupt()
    finished = False
    try:
        with pytest.raises(KeyboardInterrupt), held_while_loading():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.1)  # a stop not held is raised here, inside the block
            finished = True
    finally:
        signal.signal(signal.SIGTERM, before[0])
        signal.signal(signal.SIGINT, before[1])
        release.set()
        other.join()
    assert finished and signals.stopped()


def test_a_config_error_after_a_stop_signal_is_the_stop(monkeypatch):
    """A signal that lands inside the config library can leave it broken midway, and the error
    that follows names a config key: after a stop it is the stop (exit 130), not a user error
    (exit 2); without a stop the same error stays a user error."""
    error = ConfigKeyError("'NoneType' object has no attribute '_invalidate_flags_cache'")
    monkeypatch.setattr(preflight, "stopped", lambda: False)
    with pytest.raises(SystemExit) as user_error, user_errors(debug=False):
        raise error
    assert user_error.value.code == EXIT_USER_ERROR
    monkeypatch.setattr(preflight, "stopped", lambda: True)
    with pytest.raises(KeyboardInterrupt), user_errors(debug=False):
        raise error
