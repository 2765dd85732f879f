"""What a tune leaves in its run folder: `tune_best/best.yaml`, summary.json, summary.md,
history.png and importance.png (Optuna's matplotlib plots), all from the whole study (every
process's trials).

best.yaml is a `# @package _global_` config of the best trial's keys in a config-group folder
(`tune_best`) of the run folder, so Hydra loads it as it loads any group option once the run
folder is on its search path: `python -m grace --config-dir <run> +tune_best=best`. Copied to
grace/conf/experiment/<name>.yaml it is an experiment file (`experiment=<name>`).
"""

from __future__ import annotations

import logging
import shlex
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import optuna
from omegaconf import DictConfig, OmegaConf

from grace.cli.tune_space import nested
from grace.data.atomic import write_json_atomic, write_text_atomic
from grace.visualisation.plots import save_figure

log = logging.getLogger(__name__)

BEST_GROUP = "tune_best"


@dataclass
class TuneReport:
    """The study's best value (None without a complete trial) and the closing message."""

    best_value: float | None
    message: str


def base_overrides(overrides: list[str], tuned: set[str]) -> list[str]:
    """The tune's command-line overrides that shape a trial's config: without the task, the
    tune group, Hydra's own keys, the run folder's paths and the keys the trials set."""

    def key(override: str) -> str:
        return override.split("=", 1)[0].lstrip("+~")

    def kept(key: str) -> bool:
        return key.split(".")[0].split("/")[0] not in ("task", "tune", "hydra") and key not in (
            tuned | {"paths.output_dir", "paths.fit_dir", "paths.log_file"}
        )

    return [o for o in overrides if kept(key(o))]


def _importances(study: optuna.Study, seed: int) -> dict[str, float]:
    """fANOVA importances (seeded); empty below two complete trials."""
    complete = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))
    if len(complete) < 2:
        return {}
    evaluator = optuna.importance.FanovaImportanceEvaluator(seed=seed)
    return optuna.importance.get_param_importances(study, evaluator=evaluator)


def _trial_row(trial: optuna.trial.FrozenTrial) -> dict[str, Any]:
    return {
        "number": trial.number,
        "state": trial.state.name,
        "value": trial.value,
        "params": trial.params,
        "folds": trial.user_attrs,
        "epochs_reported": len(trial.intermediate_values),
        "seconds": trial.duration.total_seconds() if trial.duration else None,
    }


def _markdown(summary: dict[str, Any]) -> str:
    lines = [
        f"# Tune: study `{summary['study_name']}`",
        "",
        f"{summary['direction']} `{summary['metric']}` (validation assemblies, mean over "
        f"{summary['folds'] or 'all'} folds). Trials: "
        + ", ".join(f"{n} {state.lower()}" for state, n in summary["states"].items())
        + ".",
        "",
    ]
    best = summary["best"]
    if best:
        lines += [f"Best: trial {best['number']}, value {best['value']:.4f}", ""]
        lines += ["| key | value |", "| --- | --- |"]
        lines += [f"| `{k}` | {v} |" for k, v in best["params"].items()]
        lines += ["", f"Reproduce: `{summary['reproduce']}`", ""]
    if summary["importances"]:
        lines += ["| key | importance (fANOVA) |", "| --- | --- |"]
        lines += [f"| `{k}` | {v:.3f} |" for k, v in summary["importances"].items()]
        lines.append("")
    lines += [f"Dashboard: `{summary['dashboard']}`", ""]
    return "\n".join(lines)


def _plot(draw: Any, study: optuna.Study, path: Path, **kwargs: Any) -> None:
    ax = draw(study, **kwargs)
    save_figure(ax.figure, path)
    plt.close(ax.figure)


def write_best(trial: optuna.trial.FrozenTrial, summary: dict[str, Any], out_dir: Path) -> Path:
    """best.yaml: the best trial's keys as a `# @package _global_` config."""
    path = out_dir / BEST_GROUP / "best.yaml"
    header = [
        "# @package _global_",
        f"# Best trial {trial.number} of study {summary['study_name']}: "
        f"{summary['metric']} = {trial.value:.6g} ({summary['direction']}).",
        f"# Use: {summary['reproduce']}",
    ]
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, "\n".join(header) + "\n" + OmegaConf.to_yaml(nested(trial.params)))
    return path


def write_report(
    study: optuna.Study, cfg: DictConfig, out_dir: Path, storage: str, overrides: list[str]
) -> TuneReport:
    """Write best.yaml, the summary and the plots of `study` into `out_dir`."""
    trials = study.get_trials(deepcopy=False)
    complete = [t for t in trials if t.state is optuna.trial.TrialState.COMPLETE]
    importances = _importances(study, int(cfg.seed))
    tuned = {key for t in trials for key in t.params}
    command = ["python", "-m", "grace", "--config-dir", str(out_dir), f"+{BEST_GROUP}=best"]
    summary: dict[str, Any] = {
        "study_name": study.study_name,
        "storage": storage,
        "direction": str(cfg.tune.direction),
        "metric": cfg.tune.metric,
        "folds": cfg.tune.folds,
        "n_trials": len(trials),
        "states": dict(Counter(t.state.name for t in trials)),
        "best": None,
        "importances": importances,
        "reproduce": shlex.join(command + base_overrides(overrides, tuned)),
        "dashboard": f"optuna-dashboard {storage}",
        "trials": [_trial_row(t) for t in trials],
    }
    message = f"no complete trial in study {study.study_name}"
    if complete:
        best = study.best_trial
        summary["best"] = {"number": best.number, "value": best.value, "params": best.params}
        path = write_best(best, summary, out_dir)
        message = f"best trial {best.number}: {best.value:.4f}; {path}; {summary['reproduce']}"
        history = optuna.visualization.matplotlib.plot_optimization_history
        _plot(history, study, out_dir / "history.png")
    if importances:
        evaluator = optuna.importance.FanovaImportanceEvaluator(seed=int(cfg.seed))
        _plot(
            optuna.visualization.matplotlib.plot_param_importances,
            study,
            out_dir / "importance.png",
            evaluator=evaluator,
        )
    write_json_atomic(out_dir / "summary.json", summary)
    write_text_atomic(out_dir / "summary.md", _markdown(summary))
    return TuneReport(summary["best"]["value"] if complete else None, message)
