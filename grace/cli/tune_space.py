"""The search space of `task=tune` as config: each entry names a config key and its range.

A trial's parameters are named by their config keys (`model.optimizer.lr`), so Optuna's
storage, its dashboard and `best.yaml` all speak the config's own language, and a trial's config
is the composed config with those keys set (`trial_config`).
"""

from __future__ import annotations

import copy
import enum
from dataclasses import dataclass, field
from typing import Any

import optuna
from omegaconf import MISSING, DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from grace.errors import UserError
from grace.roles import WEIGHTS

_ABSENT = object()


@dataclass
class Param:
    """One searched key: `choices`, or a `low`–`high` range (integer when both are integers;
    `log` samples the log scale, `step` a grid)."""

    key: str = MISSING
    low: Any = None
    high: Any = None
    log: bool = False
    step: Any = None
    choices: list[Any] | None = None


class Direction(enum.StrEnum):
    """Whether the tune's metric improves upwards or downwards."""

    minimize = "minimize"
    maximize = "maximize"


@dataclass
class TuneConfig:
    """Schema of the `tune` group (values and comments in grace/conf/tune/default.yaml)."""

    study_name: str = field(default=MISSING, metadata=WEIGHTS)
    storage: str | None = field(default=None, metadata=WEIGHTS)
    n_trials: int = field(default=MISSING, metadata=WEIGHTS)
    timeout: float | None = field(default=None, metadata=WEIGHTS)
    folds: int | None = field(default=None, metadata=WEIGHTS)
    metric: str = field(default=MISSING, metadata=WEIGHTS)
    direction: Direction = field(default=Direction.maximize, metadata=WEIGHTS)
    sampler: Any = field(default=MISSING, metadata=WEIGHTS)
    pruner: Any = field(default=None, metadata=WEIGHTS)
    # Untyped here (each entry is checked as a Param when the tune starts): Hydra's command
    # line cannot add a dict to a typed dict of dataclasses ('+tune.space.x={key: ...}').
    space: Any = field(default_factory=dict, metadata=WEIGHTS)


def _param(name: str, entry: Any, cfg: DictConfig) -> Param:
    """`tune.space.<name>` as a checked Param."""
    where = f"tune.space.{name}"
    try:
        param = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(Param), entry))
    except OmegaConfBaseException as error:
        raise UserError(f"{where}: {error}".split("\n")[0]) from None
    if OmegaConf.select(cfg, param.key, default=_ABSENT) is _ABSENT:
        raise UserError(f"{where}.key={param.key}: no such key in the config; fix the key")
    ranged = param.low is not None and param.high is not None
    if (param.choices is not None) == ranged:
        raise UserError(f"{where}: give either choices or both low and high")
    if ranged and not param.low < param.high:
        raise UserError(f"{where}: low={param.low} must be below high={param.high}")
    if param.choices is not None and not param.choices:
        raise UserError(f"{where}.choices is empty; list at least one value")
    return param


def parse_space(space: DictConfig, cfg: DictConfig) -> list[Param]:
    """The entries of `tune.space` as Params, each checked against `cfg` (entries set to null
    are dropped: a derived space removes a key of the one it extends that way)."""
    return [_param(str(name), entry, cfg) for name, entry in space.items() if entry is not None]


def suggest(trial: optuna.Trial, params: list[Param]) -> dict[str, Any]:
    """The trial's value of every param, by config key."""
    values = {}
    for param in params:
        if param.choices is not None:
            values[param.key] = trial.suggest_categorical(param.key, list(param.choices))
        elif isinstance(param.low, int) and isinstance(param.high, int):
            values[param.key] = trial.suggest_int(
                param.key, param.low, param.high, step=param.step or 1, log=param.log
            )
        else:
            values[param.key] = trial.suggest_float(
                param.key, float(param.low), float(param.high), step=param.step, log=param.log
            )
    return values


def trial_config(cfg: DictConfig, values: dict[str, Any]) -> DictConfig:
    """A copy of `cfg` with each key of `values` set (typed: a value the key's schema refuses
    stops the tune naming the key)."""
    out = copy.deepcopy(cfg)
    for key, value in values.items():
        try:
            OmegaConf.update(out, key, value, merge=False)
        except OmegaConfBaseException as error:
            message = f"tune.space: {key}={value!r} is refused: {error}".split("\n")[0]
            raise UserError(message) from None
    return out


def nested(values: dict[str, Any]) -> dict[str, Any]:
    """`{"a.b": 1, "a.c": 2}` -> `{"a": {"b": 1, "c": 2}}`: dotted keys as a config tree."""
    tree: dict[str, Any] = {}
    for key, value in values.items():
        *parents, leaf = key.split(".")
        node = tree
        for parent in parents:
            node = node.setdefault(parent, {})
        node[leaf] = value
    return tree
