"""task=tune: a study of n trials, best.yaml as a config, a second process on one study, pruning,
and one trial with real training whose value is read back from Lightning's own metrics log."""

import csv
import json
import os
import re
import shlex
import subprocess
import sys
import threading
from pathlib import Path

import optuna
import pytest
import tune_fakes
from omegaconf import OmegaConf

from grace.cli.tune_space import parse_space, suggest, trial_config
from grace.errors import UserError
from grace.tasks.tune import KeptMetric, open_study, run

ROOT = Path(__file__).resolve().parents[2]
TASKS = Path(__file__).resolve().parent
FAKES = (  # puzzles instead of simulator data, the closed-form trainer of tune_fakes
    "~dataset",
    "+dataset={_target_: experiment_fakes.PuzzleSource, seed: 0}",
    "task.fit._target_=tune_fakes.fit",
)
SMALL = ("threads=1", "trainer.max_epochs=4", "tune.folds=2", "tune.pruner=null")


def _study(out: Path, name: str = "grace") -> optuna.Study:
    return optuna.load_study(study_name=name, storage=f"sqlite:///{out / 'study.db'}")


def test_tune_writes_a_study_of_n_trials_and_its_report(tmp_path, cfg_factory):
    cfg = cfg_factory("task=tune", *FAKES, *SMALL, "tune.n_trials=3")
    best = run(cfg)
    out = Path(cfg.paths.output_dir)
    trials = _study(out).trials
    assert len(trials) == 3 and all(t.state.name == "COMPLETE" for t in trials)
    for trial in trials:  # each value is the fake's kept-epoch metric under the trial's keys
        assert trial.value == pytest.approx(tune_fakes.kept_value(trial_config(cfg, trial.params)))
        assert set(trial.user_attrs) == {"fold_0", "fold_1"}
    assert best == pytest.approx(max(t.value for t in trials))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["states"] == {"COMPLETE": 3} and summary["best"]["value"] == best
    assert set(summary["importances"]) == set(trials[0].params)
    assert (out / "history.png").stat().st_size > 0 and (out / "importance.png").exists()
    assert "optuna-dashboard sqlite:///" in (out / "summary.md").read_text()


@pytest.mark.slow  # a second tuning run to compare with
def test_best_yaml_loads_and_reproduces_the_best_trial(tmp_path, cfg_factory):
    base = ("task=tune", *FAKES, *SMALL, "tune.n_trials=3")
    cfg = cfg_factory(*base)
    run(cfg)
    out = Path(cfg.paths.output_dir)
    best = _study(out).best_trial
    expected = OmegaConf.to_container(trial_config(cfg, best.params), resolve=False)
    # The command that best.yaml gives, composed as the command line would (--config-dir puts
    # the run folder on the search path).
    (use,) = [line for line in (out / "tune_best" / "best.yaml").open() if "# Use: " in line]
    command = shlex.split(use.split("# Use: ")[1])
    assert command[:6] == ["python", "-m", "grace", "--config-dir", str(out), "+tune_best=best"]
    assert not any(o.startswith(("task", "tune", "paths.output_dir")) for o in command[6:])
    again = cfg_factory(f"hydra.searchpath=[file://{out}]", *command[5:])
    loaded = OmegaConf.to_container(again, resolve=False)
    for key in best.params:
        assert OmegaConf.select(again, key) == best.params[key]
    for group in set(expected) - {"task", "tune", "paths"}:
        assert loaded[group] == expected[group], group


@pytest.mark.slow  # a fast twin covers the behaviour; this one is end to end
def test_a_second_process_adds_to_the_same_study(tmp_path, cfg_factory):
    cfg = cfg_factory("task=tune", *FAKES, *SMALL, "tune.n_trials=3")
    run(cfg)
    first = Path(cfg.paths.output_dir)
    second = tmp_path / "second"
    cmd = [
        sys.executable, "-m", "grace", "task=tune", *FAKES, *SMALL, "tune.n_trials=2",
        f"tune.storage=sqlite:///{first / 'study.db'}", f"hydra.run.dir={second}",
    ]  # fmt: skip
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(TASKS), str(ROOT)])}
    subprocess.run(cmd, cwd=ROOT, env=env, check=True, capture_output=True, timeout=120)
    trials = _study(first).trials
    assert len(trials) == 5 and [t.number for t in trials] == list(range(5))
    points = {tuple(sorted(t.params.items())) for t in trials}
    assert len(points) == 5  # the sampler is seeded past the trials already there
    summary = json.loads((second / "summary.json").read_text())
    assert summary["n_trials"] == 5 and not (second / "study.db").exists()


@pytest.mark.slow  # a study of real trials; the study and its report have fast tests
def test_pruning_stops_bad_trials_on_the_first_fold(tmp_path, cfg_factory):
    cfg = cfg_factory(
        "task=tune", *FAKES, *SMALL[:3], "tune.n_trials=10", "tune.sampler.n_startup_trials=10",
        "tune.pruner.n_startup_trials=2", "tune.pruner.n_warmup_steps=0",
    )  # fmt: skip
    run(cfg)
    trials = _study(Path(cfg.paths.output_dir)).trials
    pruned = [t for t in trials if t.state.name == "PRUNED"]
    assert pruned, "no trial pruned"
    for trial in pruned:  # stopped inside fold 0: fewer epochs reported, fold 1 never trained
        assert len(trial.intermediate_values) < 4 and "fold_1" not in trial.user_attrs
        bar = sorted(
            t.intermediate_values[max(trial.intermediate_values)]
            for t in trials
            if t.number < trial.number and t.state.name == "COMPLETE"
        )
        assert trial.intermediate_values[max(trial.intermediate_values)] < bar[len(bar) // 2]
    summary = json.loads((Path(cfg.paths.output_dir) / "summary.json").read_text())
    assert summary["states"]["PRUNED"] == len(pruned)


def test_kept_metric_is_read_at_the_best_monitored_epoch():
    kept = KeptMetric("val_step_auc", "val_loss", "min")
    kept.epochs = [(0.5, 0.9), (0.7, 0.4), (0.9, 0.4), (0.8, 0.6)]
    assert kept.kept() == 0.7  # ties keep the earliest, as the checkpoint does
    kept.mode = "max"
    assert kept.kept() == 0.5
    with pytest.raises(UserError, match=re.escape("tune.metric=val_step_auc")):
        KeptMetric("val_step_auc", "val_loss", "min").kept()


def test_a_space_key_missing_from_the_config_is_named(tmp_path, cfg_factory):
    cfg = cfg_factory(
        "task=tune", *FAKES, *SMALL, "tune.n_trials=1",
        "+tune.space.typo={key: model.optimizer.lrr, low: 0.1, high: 0.2}",
    )  # fmt: skip
    with pytest.raises(UserError, match=re.escape("tune.space.typo.key=model.optimizer.lrr")):
        run(cfg)
    assert not (Path(cfg.paths.output_dir) / "study.db").exists()  # stopped before the study


def test_one_real_trial_scores_the_kept_epoch_of_lightnings_log(tmp_path, cfg_factory):
    """Real GRACE training (2 epochs on puzzles) with the pruning callback on: the trial's value
    is val_step_auc at the lowest val_loss in the fold's CSV log, and the pruner got every
    epoch's val_step_auc."""
    cfg = cfg_factory(
        "task=tune", *FAKES[:2], "threads=1", "trainer.max_epochs=2", "tune.folds=1",
        "tune.n_trials=1", "tune.space={}", "model.net.hidden=16",
    )  # fmt: skip
    value = run(cfg)
    out = Path(cfg.paths.output_dir)
    (metrics,) = (out / "trial_0" / "fold_0").rglob("metrics.csv")
    rows = [r for r in csv.DictReader(metrics.open()) if r.get("val_loss")]
    assert len(rows) == 2
    kept = min(rows, key=lambda r: float(r["val_loss"]))
    assert value == pytest.approx(float(kept["val_step_auc"]), abs=1e-6)
    (trial,) = _study(out).trials
    reported = [trial.intermediate_values[epoch] for epoch in (0, 1)]
    assert reported == pytest.approx([float(r["val_step_auc"]) for r in rows], abs=1e-6)


def test_a_derived_space_drops_and_adds_keys_and_ranges_hold(cfg_factory):
    cfg = cfg_factory("task=tune", "tune=training")
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    for _ in range(20):
        values = suggest(study.ask(), parse_space(cfg.tune.space, cfg))
        assert set(values) == {
            "model.optimizer.lr",
            "callbacks.early_stopping.patience",
            "datamodule.batch_size",
            "trainer.max_epochs",
        }
        assert 3e-4 <= values["model.optimizer.lr"] <= 1e-2
        assert values["trainer.max_epochs"] in (12, 16, 24)
        assert values["datamodule.batch_size"] in (64, 128, 256)
        trial = trial_config(cfg, values)
        assert (
            trial.model.scheduler.T_max == trial.trainer.max_epochs == values["trainer.max_epochs"]
        )


def test_a_value_the_schema_refuses_is_named(cfg_factory):
    cfg = cfg_factory("task=tune", "tune.space.hidden.low=32.5")  # a float for an int key
    with pytest.raises(UserError, match=re.escape("model.net.hidden=")):
        trial_config(cfg, suggest(optuna.create_study().ask(), parse_space(cfg.tune.space, cfg)))


def test_tune_reads_the_selection_data_set_and_experiments_the_evaluation_one(cfg_factory):
    """Defaults are chosen on the selection data set (seed 1), figures reported on the
    evaluation data set (seed 0), whatever the training seed (docs/training.md)."""
    assert cfg_factory().dataset.seed == 0 and cfg_factory("seed=3").dataset.seed == 0
    assert cfg_factory("experiment=selection").dataset.seed == 1
    assert cfg_factory("task=tune").dataset.seed == 1
    assert cfg_factory("task=tune", "dataset.seed=0").dataset.seed == 0


@pytest.mark.slow  # a fast twin covers the behaviour; this one is end to end
def test_processes_opening_one_new_study_at_once_all_get_it(tmp_path, cfg_factory):
    """Three openers of one new SQLite study at the same moment (threads, each with its own
    connection, as processes have): every one gets the study, in each of ten tries.
    tests/tasks/tune_race.py measures the same with whole task=tune processes."""
    cfg = cfg_factory("task=tune", *FAKES, *SMALL, "tune.n_trials=1")
    for attempt in range(10):
        url = f"sqlite:///{tmp_path / f'study_{attempt}.db'}"
        start, opened, failed = threading.Barrier(3), [], []

        def open_one(url=url, start=start, opened=opened, failed=failed):
            start.wait()
            try:
                opened.append(open_study(cfg, url).study_name)
            except Exception as error:  # the failure is the finding
                failed.append(error)

        openers = [threading.Thread(target=open_one) for _ in range(3)]
        for opener in openers:
            opener.start()
        for opener in openers:
            opener.join()
        assert not failed, f"try {attempt}: {failed[0]!r}"
        assert opened == ["grace"] * 3
        assert optuna.get_all_study_names(storage=url) == ["grace"]
