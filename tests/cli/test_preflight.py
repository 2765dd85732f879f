"""Bad input through the real entry point: one line naming what, where and the fix, exit code 2,
nothing written, and no torch or Lightning loaded first (the checks run in about a second;
grace/cli/preflight.py). One row per kind of bad input.

Every row runs in the default suite through `grace.__main__.main` in this process (`here`), and
as a real command in a fresh interpreter (`command`), which alone can tell that no heavy module
was imported before the error: every row under `-m slow` (a command costs a second of
interpreter start-up and imports each; the default suite keeps its budget).
"""

import os
import re
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hydra.core.global_hydra import GlobalHydra
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.utils import instantiate

import grace.__main__ as entry
from grace.cli.checks import check_model_inputs
from grace.data.raw_format import export_raw
from grace.errors import UserError

ROOT = Path(__file__).resolve().parents[2]
TINY = "dataset.sizes={3: 4, 4: 4}"  # no shell: no quotes
HEAVY = ("torch", "lightning", "torch_geometric")


def grace(
    cwd: Path, *overrides: str, env: dict[str, str] | None = None
) -> tuple[int, list[str], set[str], float]:
    """Exit code, our stderr lines, the top-level modules imported, and seconds."""
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "grace", *overrides],
        cwd=cwd,
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", **(env or {})},
        capture_output=True,
        text=True,
        timeout=120,
    )
    seconds = time.perf_counter() - start
    lines = done.stderr.splitlines()
    ours = [line for line in lines if not line.startswith("import time:")]
    modules = {
        line.split("|")[-1].strip().split(".")[0] for line in lines if line.startswith("import")
    }
    return done.returncode, ours + done.stdout.splitlines(), modules, seconds


def modes(table: dict) -> list:
    """(case, mode) for every row of `table`: `here` always, `command` (a fresh interpreter)
    under `-m slow` (module docstring)."""
    return [
        *(pytest.param(case, "here", id=f"{case}-here") for case in table),
        *(
            pytest.param(case, "command", id=f"{case}-command", marks=pytest.mark.slow)
            for case in table
        ),
    ]


@pytest.fixture
def refused(monkeypatch, capsys) -> Callable[..., tuple[int, list[str], set[str], float]]:
    """`refused(mode, cwd, *overrides, env=...)`: as :func:`grace` for mode `command`; for mode
    `here`, `grace.__main__.main` in this process (its modules: none, not observable here)."""

    def run(mode: str, cwd: Path, *overrides: str, env: dict[str, str] | None = None):
        if mode == "command":
            return grace(cwd, *overrides, env=env)
        monkeypatch.chdir(cwd)
        for name, value in (env or {}).items():
            monkeypatch.setenv(name, value)
        monkeypatch.setattr(sys, "argv", ["grace", *overrides])
        handler, start = signal.getsignal(signal.SIGTERM), time.perf_counter()
        try:
            with pytest.raises(SystemExit) as stop:
                entry.main()
        finally:
            signal.signal(signal.SIGTERM, handler)
            GlobalHydra.instance().clear()
        out = capsys.readouterr()
        lines = out.err.splitlines() + out.out.splitlines()
        return stop.value.code, lines, set(), time.perf_counter() - start

    return run


def files(folder: Path) -> set[Path]:
    return {p.relative_to(folder) for p in folder.rglob("*")}


@pytest.fixture
def raw(tmp_path, fake_simulator) -> Path:
    """Two raw assembly folders (sizes 3 and 4)."""
    simulator = instantiate(fake_simulator)
    for size in (3, 4):
        sample = simulator.sample(size, np.random.default_rng(size))
        sample.assembly.name, sample.info = f"a{size}", {}
        export_raw(sample, tmp_path / "raw" / f"a{size}")
    return tmp_path / "raw"


def _spec(raw: Path) -> Path:
    return raw / "a3" / "assembly.spec"


CASES = {
    "train size not in the data set": (
        ("protocol=one_to_many", "train_size=9", TINY),
        r"protocol one_to_many: sizes \[9\] are not in the data set \(sizes \[3, 4\]\); fix: ",
    ),
    "seed not an integer": (
        ("seed=abc",),
        r"override seed=abc: Value 'abc' .* Integer \(config key 'seed'\); fix: ",
    ),
    "fold count not an integer": (
        ("protocol.folds=four",),
        r"Integer \(config key 'protocol.folds'\); fix: ",
    ),
    "sizes not integers": (
        ("dataset.sizes={3: many}",),
        r"dataset.sizes=\{3: 'many'\} is not a mapping of integers; fix: ",
    ),
    "more folds than assemblies": (
        ("protocol.folds=5", TINY),
        r"protocol.folds=5 leaves fold 4 with 0 test and 6 training assemblies .*; "
        r"fix: protocol.folds=4$",
    ),
    "two raw assemblies, four folds": (
        ("dataset=raw", "dataset.path={raw}", "dataset.sizes=null"),
        r"protocol intra: protocol.folds=4 leaves fold 0 with 2 test and 0 training assemblies "
        r"\(assemblies per size \{3: 1, 4: 1\}.*; fix: a larger data set",
    ),
    "raw path missing": (
        ("dataset=raw", "dataset.path={raw}/nowhere"),
        r"{raw}/nowhere: not a folder; fix: set dataset.path to a folder of raw assembly folders",
    ),
    "raw path not given": (
        ("dataset=raw",),
        r"dataset=raw needs dataset.path; fix: add dataset.path=",
    ),
    "malformed raw folder": (
        ("dataset=raw", "dataset.path={raw}"),
        r"1 of 2 raw folders under {raw} is malformed: {raw}/a3/assembly.spec:2: .*; fix: ",
    ),
    "unknown config option": (
        ("protocol=sideways",),
        r"Could not find 'protocol/sideways'.*; fix: ",
    ),
}


@pytest.mark.parametrize(("case", "mode"), modes(CASES))
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path, raw, refused, case, mode):
    overrides, expected = CASES[case]
    if case == "malformed raw folder":
        spec = _spec(raw)
        lines = spec.read_text().splitlines()
        spec.write_text("\n".join([lines[0], lines[1].replace(" 0;", " 2;", 1), *lines[2:]]))
    before = files(tmp_path)
    args = [o.replace("{raw}", str(raw)) for o in overrides]
    code, lines, modules, seconds = refused(
        mode, tmp_path, *args, f"paths.data_dir={tmp_path / 'd'}"
    )
    assert code == 2, lines
    assert len(lines) == 1, lines
    assert lines[0].startswith("grace: error: ")
    assert re.search(expected.replace("{raw}", re.escape(str(raw))), lines[0]), lines[0]
    assert files(tmp_path) == before  # no run folder, no log, no cache
    assert not modules & set(HEAVY), f"{case}: heavy imports before the error ({seconds:.1f} s)"


VALUES = {
    "negative seed": (("seed=-1",), r"seed=-1 is outside \[0, 4294967295\]; fix: seed=0"),
    "no threads": (("threads=0",), r"threads=0 is outside \[1, ∞\); fix: threads=1"),
    "k of 0": (("task=plan", "planner.k=0"), r"planner.k=0 is outside \[1, ∞\); fix: planner.k=1"),
    "λ above 1": (("task.threshold=1.5",), r"task.threshold=1.5 is outside \[0, 1\]; fix: "),
    "λ below 0": (
        ("task=plan", "planner=topk", "planner.threshold=-0.1"),
        r"planner.threshold=-0.1 is outside ",
    ),
    "no epochs": (("trainer.max_epochs=0",), r"trainer.max_epochs=0 is outside \[1, ∞\); fix: "),
    "dead-end target": (
        ("datamodule.dead_end_target=2.0",),
        r"datamodule.dead_end_target=2 is outside \[0, 0.5\); fix: ",
    ),
    "size beyond the cell's slots": (
        ("dataset.sizes={40: 2}",),
        r"dataset.sizes: sizes \[40\] exceed simulator.cell.max_parts=20 .*; fix: sizes from 2",
    ),
    "count of 0": (
        ("dataset.sizes={3: 0}",),
        r"dataset.sizes has invalid entries \{3: 0\}; fix: sizes ≥ 1 and counts ≥ 1",
    ),
    "GRACE_DATA_DIR a file": (
        ("GRACE_DATA_DIR={file}",),
        r"paths.data_dir={file} is a file, not a folder; fix: set paths.data_dir \(or "
        r"GRACE_DATA_DIR\) to a folder",
    ),
    "run folder under a file": (
        ("paths.output_dir={file}/run",),
        r"paths.output_dir={file}/run lies under the file {file}; fix: ",
    ),
    "read-only data folder": (
        ("paths.data_dir={ro}/data",),
        r"paths.data_dir={ro}/data: the folder {ro} is not writable .*; fix: ",
    ),
    "read-only run folder": (
        ("paths.output_dir={ro}/run",),
        r"paths.output_dir={ro}/run: the folder {ro} is not writable .*; fix: ",
    ),
}
"""Values out of range and unusable folders: refused by the preflight (grace/cli/values.py)
before anything is generated, trained or written."""


@pytest.fixture
def read_only(tmp_path) -> Path:
    """A folder nobody may write to: a chmod 555 one, or for root (whom permissions do not stop)
    /sys, where no file can be created."""
    if os.geteuid() == 0:
        return Path("/sys")
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    return folder


@pytest.mark.parametrize(("case", "mode"), modes(VALUES))
def test_a_bad_value_is_refused_before_any_work(tmp_path, read_only, refused, case, mode):
    arguments, expected = VALUES[case]
    (tmp_path / "file").write_text("not a folder\n")
    before = files(tmp_path)
    places = {"{file}": str(tmp_path / "file"), "{ro}": str(read_only)}
    for place, value in places.items():
        arguments = [a.replace(place, value) for a in arguments]
        expected = expected.replace(place, re.escape(value))
    env = dict(a.split("=", 1) for a in arguments if a.startswith("GRACE_DATA_DIR="))
    overrides = [a for a in arguments if not a.startswith("GRACE_DATA_DIR=")]
    if not env and not any(a.startswith("paths.data_dir=") for a in overrides):
        overrides.append(f"paths.data_dir={tmp_path / 'd'}")
    code, lines, modules, seconds = refused(mode, tmp_path, *overrides, env=env)
    assert code == 2, lines
    assert len(lines) == 1 and lines[0].startswith("grace: error: "), lines
    assert re.search(expected, lines[0]), lines[0]
    assert files(tmp_path) == before  # no run folder, no log, no cache
    assert not modules & set(HEAVY), f"{case}: heavy imports before the error ({seconds:.1f} s)"


def test_an_option_the_protocol_ignores_is_named_at_once(tmp_path):
    """`train_size=5 protocol=intra`: a warning before any work; the run itself goes on (here it
    then stops on a second, deliberate error, so the test does no work either)."""
    code, lines, modules, _ = grace(
        tmp_path, "train_size=5", "protocol=intra", TINY, "protocol.folds=9"
    )
    assert lines[0] == (
        "grace: warning: train_size=5 is ignored by protocol=intra (it does not use train_size); "
        "fix: drop it, or choose a protocol that uses it (docs/protocols.md)"
    )
    assert code == 2 and len(lines) == 2 and lines[1].startswith("grace: error: protocol intra")
    assert not modules & set(HEAVY)


@pytest.mark.parametrize("ask", [("debug=true",), ("HYDRA_FULL_ERROR=1",)])
def test_the_traceback_comes_on_request(tmp_path, ask):
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}
    overrides = ["seed=abc"]
    if ask[0].startswith("HYDRA"):
        env["HYDRA_FULL_ERROR"] = "1"
    else:
        overrides += ask
    done = subprocess.run(
        [sys.executable, "-m", "grace", *overrides],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode != 0
    assert "Traceback (most recent call last)" in done.stderr
    assert "could not be converted to Integer" in done.stderr
    assert not list(tmp_path.iterdir())


PROBE = {
    "seed beyond numpy's": (("seed=4294967296",), r"seed=4294967296 is outside \[0, 4294967295\]"),
    "batch of 0": (("datamodule.batch_size=0",), r"datamodule.batch_size=0 is outside \[1, ∞\)"),
    "negative learning rate": (("model.optimizer.lr=-1",), r"model.optimizer.lr=-1 is outside "),
    "a size of one part": (
        ("dataset.sizes={1: 10, 3: 10}",),
        r"assemblies of \[1\] part\(s\), fewer than the 2 .*; fix: 'dataset.sizes=\{3: 10\}'$",
    ),
    "planning one part": (
        ("task=plan", "ckpt={run}", "assembly={one}"),
        r"assembly={one}: 1 part; planning needs 2 or more .*; fix: ",
    ),
    "more parts than the cell's slots": (
        ("task=plan", "planner=topk", "ckpt={run}", "assembly={many}"),
        r"assembly={many}: 21 parts, but the cell it is planned in has 20 part slots .*; fix: an "
        r"assembly of at most 20 parts, or task.kept_world=false simulator=large_frames .*\)$",
    ),
    "more parts than the chosen cell's slots": (
        (
            "task=plan",
            "ckpt={run}",
            "assembly={many}",
            "task.kept_world=false",
            "simulator.cell.max_parts=20",
        ),
        r"assembly={many}: 21 parts, but the cell it is planned in has 20 part slots",
    ),
    "kept config not YAML": (
        ("task=plan", "ckpt={broken}", "assembly={raw}/a3"),
        r"{broken}/config.yaml:\d+: not valid YAML .*; fix: use a run folder whose ",
    ),
    "unknown interpolation": (
        ("paths.output_dir=${oops}",),
        r"paths.output_dir=\$\{oops\}: Interpolation key 'oops' not found; fix: ",
    ),
    "hydra.run.dir under a file": (
        ("hydra.run.dir={file}/run",),
        r"hydra.run.dir={file}/run lies under the file {file}; fix: ",
    ),
    "negative search time": (("planner.max_seconds=-1",), r"planner.max_seconds=-1 is outside "),
    "no step checks": (("planner.max_checks=0",), r"planner.max_checks=0 is outside \[1, ∞\)"),
    "negative patience": (
        ("callbacks.early_stopping.patience=-1",),
        r"callbacks.early_stopping.patience=-1 is outside \[0, ∞\); fix: ",
    ),
    "negative trials": (("task=tune", "tune.n_trials=-1"), r"tune.n_trials=-1 is outside "),
    "no fold jobs": (("task.fold_jobs=0",), r"task.fold_jobs=0 is outside \[1, ∞\); fix: "),
    "one fold": (("protocol.folds=1",), r"protocol.folds=1 is outside \[2, ∞\); fix: "),
    "validation share of 1.5": (
        ("protocol.val_fraction=1.5",),
        r"protocol.val_fraction=1.5 is outside \[0, 1\); fix: protocol.val_fraction=0 ",
    ),
    "no tune folds": (("task=tune", "tune.folds=0"), r"tune.folds=0 is outside \[1, ∞\); fix: "),
    "chunks of 0": (("dataset.chunk_size=0",), r"dataset.chunk_size=0 is outside \[1, ∞\)"),
    "shard beyond the shards": (
        ("dataset.shard=2", "dataset.num_shards=2"),
        r"dataset.shard=2 is not below dataset.num_shards=2; fix: dataset.shard=0 to 1 ",
    ),
    "raw data, scale's sizes": (  # the raw set lacks most sizes: no warning line before
        ("dataset=raw", "dataset.path={raw}"),
        r"protocol intra: protocol.folds=4 leaves fold 0 with 2 test and 0 training",
    ),
}
"""A hostile user's command lines: values that passed the preflight and failed later (or ran
on silently), refused now in one line with a fix, before torch loads and before the run folder
exists."""


def _profiles(parts: int) -> str:
    """A raw assembly.spec of `parts` 200 mm profiles side by side."""
    pose = "1;0;0;{x}&0;1;0;0&0;0;1;0&0;0;0;1"
    rows = [f"p{i} item_profile_200 {pose.format(x=100 * i - 1000)}" for i in range(parts)]
    return "\n".join(["begin Pieces", *rows, "end Pieces"]) + "\n"


@pytest.fixture
def plan_inputs(tmp_path, raw) -> dict[str, str]:
    """A kept run (an empty checkpoint beside a config whose cell has 20 part slots), one with a
    config.yaml that is not YAML, and assemblies of 1 and 21 parts."""
    places = {"{raw}": str(raw), "{file}": str(tmp_path / "file")}
    for name, config in (("run", "model: {}\nsimulator: {cell: {max_parts: 20}}\n"),
                         ("broken", "model: [unclosed\n")):  # fmt: skip
        (tmp_path / name / "checkpoints").mkdir(parents=True)
        (tmp_path / name / "checkpoints" / "best.ckpt").write_bytes(b"")
        (tmp_path / name / "config.yaml").write_text(config)
        places[f"{{{name}}}"] = str(tmp_path / name)
    for name, parts in (("one", 1), ("many", 21)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "assembly.spec").write_text(_profiles(parts))
        places[f"{{{name}}}"] = str(tmp_path / name)
    (tmp_path / "file").write_text("not a folder\n")
    return places


@pytest.mark.parametrize(("case", "mode"), modes(PROBE))
def test_a_probed_command_line_is_refused_in_one_line_before_any_work(
    tmp_path, plan_inputs, refused, case, mode
):
    arguments, expected = PROBE[case]
    for place, value in plan_inputs.items():
        arguments = tuple(a.replace(place, value) for a in arguments)
        expected = expected.replace(place, re.escape(value))
    before = files(tmp_path)
    code, lines, modules, seconds = refused(
        mode, tmp_path, *arguments, f"paths.data_dir={tmp_path}/d"
    )
    assert code == 2, lines
    assert len(lines) == 1 and lines[0].startswith("grace: error: "), lines
    assert re.search(expected, lines[0]), lines[0]
    assert files(tmp_path) == before  # no run folder, no log, no cache
    assert not modules & set(HEAVY), f"{case}: heavy imports before the error ({seconds:.1f} s)"


@pytest.mark.parametrize("folder", ["/tmp/runs/a b", "/tmp/x,y=z[1]", "/tmp/it's here"])
def test_the_resume_hint_pastes_back_as_the_run_folder(capsys, folder):
    """The line a stopped run prints is one shell word that Hydra reads back as the folder."""
    with pytest.raises(SystemExit) as stop:
        entry._interrupted(folder)
    assert stop.value.code == 130
    hint = capsys.readouterr().out.strip().split("to resume: the same command with ")[1]
    (word,) = shlex.split(hint)
    (override,) = OverridesParser.create().parse_overrides([word])
    assert override.key_or_group == "paths.output_dir" and override.value() == folder


def test_a_large_frame_is_planned_in_the_cell_the_command_chooses(cfg_factory, plan_inputs):
    """21 parts exceed the kept cell's 20 slots; with task.kept_world=false the composed
    simulator=large_frames (50 slots) holds them."""
    given = (f"ckpt={plan_inputs['{run}']}", f"assembly={plan_inputs['{many}']}")
    with pytest.raises(UserError, match="21 parts, but the cell it is planned in has 20"):
        check_model_inputs(cfg_factory("task=plan", *given, "simulator=large_frames"))
    chosen = cfg_factory("task=plan", *given, "task.kept_world=false", "simulator=large_frames")
    check_model_inputs(chosen)
