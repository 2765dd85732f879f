"""Typed schemas of the config groups, registered with Hydra's ConfigStore.

A schema is built from what its config instantiates: the fields of a dataclass, or the keyword
parameters of a class, with their type hints and defaults, plus `_target_` (and `_partial_`,
`_recursive_`, `_convert_` where the config uses them). Each YAML file of a group lists its
schema first in its defaults (`- /schema/<group>@_here_`), so OmegaConf checks every value's
type when the config is composed and an error names the key: `seed=abc` fails with
"Value 'abc' ... could not be converted to Integer, full_key: seed", `model.graph.pe=learned`
with "Invalid value 'learned', expected one of [sinusoidal, random, none]". A key that the
target does not take is an error too, so a typo never passes silently.

Hand-written on purpose: hydra-zen's `builds()` makes such schemas from signatures, but (0.17)
types every `X | None` as Any, and this code base writes optional values that way everywhere;
OmegaConf itself types them.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import importlib
import inspect
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from hydra.core.config_store import ConfigStore
from omegaconf import MISSING

from grace import CONF_DIR
from grace.cli.signals import held_while_loading
from grace.data.loading import RawSource
from grace.data.store import GeneratedSource
from grace.evaluation.protocols import ProtocolSettings
from grace.roles import PLANNING, ROLE, RUN, WEIGHTS, Role
from grace.simulation.cell_config import register as register_simulator_schemas

_SCALARS = (int, float, bool, str, bytes, Path)


def config_type(hint: Any) -> Any:
    """`hint` where OmegaConf can check it (scalars, enums, dataclasses, lists of those,
    optionals); Any where it cannot (callables, objects given at run time, dicts)."""
    if hint is Any or hint in _SCALARS:
        return hint
    if isinstance(hint, type) and (issubclass(hint, enum.Enum) or dataclasses.is_dataclass(hint)):
        return hint
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (types.UnionType, typing.Union):
        inner = [a for a in args if a is not type(None)]
        kind = config_type(inner[0]) if len(inner) == 1 and len(args) == 2 else Any
        # OmegaConf 2.3 resolves an interpolation merged into an optional list or dict (which
        # fails while the config is still being composed), so those stay untyped.
        if kind is Any or typing.get_origin(kind) in (list, dict):
            return Any
        return kind | None
    if origin is list and len(args) == 1 and config_type(args[0]) is not Any:
        return list[config_type(args[0])]
    # Dicts stay untyped: Hydra's command-line override `key={3: 8}` cannot replace a typed
    # dict whose keys differ (it merges, and the struct flag refuses new keys).
    return Any


def _config_value(value: Any) -> bool:
    """Whether a Python default can stand in a config as it is."""
    if value is None or isinstance(value, (*_SCALARS, enum.Enum)):
        return True
    if isinstance(value, (list, tuple)):
        return all(_config_value(v) for v in value)
    if isinstance(value, dict):
        return all(isinstance(k, (int, str)) and _config_value(v) for k, v in value.items())
    return False


def _default(spec: dataclasses.Field) -> Any:
    if spec.default_factory is not dataclasses.MISSING:
        return spec.default_factory()
    return MISSING if spec.default is dataclasses.MISSING else spec.default


def _field(value: Any, role: Role | None) -> Any:
    metadata = {} if role is None else {ROLE: role}
    if isinstance(value, (list, tuple, dict)):
        copy = list(value) if isinstance(value, (list, tuple)) else dict(value)
        return field(default_factory=lambda: copy, metadata=metadata)
    return field(default=value, metadata=metadata)


def schema(
    target: Callable[..., Any],
    *,
    exclude: tuple[str, ...] = (),
    nested: Mapping[str, type] | None = None,
    meta: Mapping[str, Any] | None = None,
    role: Role | None = None,
    roles: Mapping[str, Role] | None = None,
) -> type:
    """A dataclass schema of the config that instantiates `target`.

    `exclude` names parameters given at run time rather than by the config, `nested` the schemas
    of parameters that are configs with their own `_target_`, `meta` Hydra's special keys and
    their values. A parameter whose default cannot stand in a config (a function, an object) is
    left out: it cannot be configured. `role` is what every key changes (grace/roles.py), but
    those `roles` names; a name in `roles` that is no key of the schema is a TypeError, so a
    declaration never outlives its key.
    """
    nested, roles = dict(nested or {}), dict(roles or {})
    if dataclasses.is_dataclass(target):
        hints = typing.get_type_hints(target)
        params = {f.name: _default(f) for f in dataclasses.fields(target) if f.init}
    else:
        init = target.__init__ if isinstance(target, type) else target
        hints = typing.get_type_hints(init)
        params = {
            p.name: MISSING if p.default is p.empty else p.default
            for p in inspect.signature(target).parameters.values()
            if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
        }
    spec: list[tuple[str, Any, Any]] = [
        ("_target_", str, _field(f"{target.__module__}.{target.__qualname__}", role))
    ]
    spec += [(key, type(value), _field(value, role)) for key, value in (meta or {}).items()]
    for name, default in params.items():
        if name in exclude:
            continue
        if name in nested:
            spec.append((name, nested[name], field(default_factory=nested[name])))
        elif default is MISSING or _config_value(default):
            kind = config_type(hints.get(name, Any))
            spec.append((name, kind, _field(default, roles.pop(name, role))))
    if roles:
        raise TypeError(
            f"roles of {target.__qualname__} name no key of its schema: {sorted(roles)}"
        )
    return dataclasses.make_dataclass(f"{target.__qualname__}Schema", spec)


class MonitorMode(enum.StrEnum):
    """Whether the monitored metric improves downwards or upwards."""

    min = "min"
    max = "max"


@dataclass
class Monitor:
    """What early stopping, the best checkpoint and the lr scheduler watch."""

    metric: str = field(default="val_loss", metadata=WEIGHTS)
    mode: MonitorMode = field(default=MonitorMode.min, metadata=WEIGHTS)


@dataclass
class Paths:
    """Where data, run outputs and logs go."""

    data_dir: str = field(default="data_cache", metadata=RUN)
    output_dir: str = field(default=MISSING, metadata=RUN)
    fit_dir: str = field(default=MISSING, metadata=RUN)
    log_file: str = field(default=MISSING, metadata=RUN)


@dataclass
class RootConfig:
    """The keys of `config.yaml` and one untyped slot per config group: a group with schemas
    declares the roles of its keys there; `classifier` and `scale` have none, so their slots
    declare theirs."""

    seed: int = field(default=0, metadata=WEIGHTS)
    threads: int = field(default=2, metadata=RUN)
    debug: bool = field(default=False, metadata=RUN)
    train_size: int = field(default=5, metadata=WEIGHTS)
    test_size: int = field(default=5, metadata=WEIGHTS)
    ckpt: str | None = field(default=None, metadata=WEIGHTS)
    assembly: str | None = field(default=None, metadata=WEIGHTS)
    path: str | None = field(default=None, metadata=WEIGHTS)
    monitor: Monitor = field(default_factory=Monitor)
    paths: Paths = field(default_factory=Paths)
    task: Any = MISSING
    simulator: Any = None
    dataset: Any = None
    model: Any = None
    datamodule: Any = None
    trainer: Any = None
    callbacks: Any = None
    logger: Any = None
    protocol: Any = None
    # task.classifiers' classifier, fitted on the kept model's embeddings
    classifier: Any = field(default=None, metadata=PLANNING)
    planner: Any = None
    threshold: Any = None
    scale: Any = field(default=None, metadata=WEIGHTS)  # the data set's sizes
    tune: Any = None


def light_schemas() -> dict[str, type]:
    """The schemas whose modules import neither torch nor Lightning: enough to check a command
    line in a second, before the heavy libraries load (grace/cli/preflight.py)."""
    return {
        "dataset/generated": schema(
            GeneratedSource,
            meta={"_recursive_": False, "_convert_": "all"},
            role=Role.weights,
            roles={"workers": Role.run, "data_dir": Role.run},
        ),
        "dataset/raw": schema(RawSource, role=Role.weights, roles={"data_dir": Role.run}),
        "protocol": ProtocolSettings,
    }


def _model_schemas() -> dict[str, type]:
    from grace.graphs.encoding import GraphEncoding
    from grace.model.grace_pyg import NetConfig
    from grace.model.module import GraceModule

    return {
        "model": schema(
            GraceModule,
            nested={
                # the score is no part of the loss: the same weights plan under every rule
                "net": schema(NetConfig, role=Role.weights, roles={"score": Role.planning}),
                "graph": schema(GraphEncoding, role=Role.weights),
            },
            role=Role.weights,
        )
    }


def _datamodule_schemas() -> dict[str, type]:
    from grace.graphs.datamodule import StateDataModule

    return {
        "datamodule": schema(
            StateDataModule,
            exclude=("train", "val", "enc", "collate"),
            meta={"_partial_": True},
            role=Role.weights,
        )
    }


def _trainer_schemas() -> dict[str, type]:
    from lightning.pytorch import Trainer

    return {
        "trainer": schema(
            Trainer,
            exclude=("callbacks", "logger", "plugins"),
            role=Role.weights,
            roles={"enable_progress_bar": Role.run},
        )
    }


def _options(group: str, role: Role, **targets: Callable[..., Any]) -> dict[str, type]:
    """`<group>/<option>` → the schema of each target, every key of `role`."""
    return {f"{group}/{name}": schema(target, role=role) for name, target in targets.items()}


def _callbacks_schemas() -> dict[str, type]:
    from lightning.pytorch.callbacks import EarlyStopping, ModelCheckpoint

    return _options(
        "callbacks", Role.weights, early_stopping=EarlyStopping, model_checkpoint=ModelCheckpoint
    )


def _logger_schemas() -> dict[str, type]:
    from lightning.pytorch.loggers import CSVLogger, TensorBoardLogger

    return _options("logger", Role.weights, csv=CSVLogger, tensorboard=TensorBoardLogger)


def _tune_schemas() -> dict[str, type]:
    from grace.cli.tune_space import TuneConfig

    return {"tune": TuneConfig}


def _planner_schemas() -> dict[str, type]:
    from grace.planning.search import VerifiedSearch
    from grace.planning.topk import TopKListing

    return _options("planner", Role.weights, verified=VerifiedSearch, topk=TopKListing)


def _threshold_schemas() -> dict[str, type]:
    from grace.planning.thresholds import AbsoluteThreshold, LiftedThreshold, RelativeThreshold

    return _options(
        "threshold",
        Role.planning,
        absolute=AbsoluteThreshold,
        relative=RelativeThreshold,
        lifted=LiftedThreshold,
    )


GROUP_SCHEMAS: dict[str, Callable[[], dict[str, type]]] = {
    "model": _model_schemas,
    "datamodule": _datamodule_schemas,
    "trainer": _trainer_schemas,
    "callbacks": _callbacks_schemas,
    "logger": _logger_schemas,
    "tune": _tune_schemas,
    "planner": _planner_schemas,
    "threshold": _threshold_schemas,
}
"""Config group → the schemas of its components, built on torch and Lightning (their modules
take seconds to import, hence imported here, on demand)."""


def heavy_schemas(run: str | None = None) -> dict[str, type]:
    """The schemas of the groups built on torch and Lightning and of the tasks; with `run` (a
    task config's `run._target_`), only that task's schema and those of the groups it reads (its
    settings' `reads`), so that a task reading no Lightning component (task=plan) does not wait
    seconds for Lightning to load."""
    tasks = task_schemas(run=run)
    reads = next(iter(tasks.values())).reads if run is not None and tasks else None
    out: dict[str, type] = {}
    for group, build in GROUP_SCHEMAS.items():
        if reads is None or group in reads:
            out |= build()
    return out | tasks


def task_schemas(conf_dir: Path = CONF_DIR, run: str | None = None) -> dict[str, type]:
    """`task/<name>` → the schema of each task config (only the one whose `run._target_` is
    `run`, if given): the TaskSettings subclass defined in the module of its `run` target. The
    task layer sits above this one, so its modules are found the way Hydra finds every target:
    by the name the config gives."""
    from grace.cli.runner import TaskSettings

    out = {}
    for path in sorted((conf_dir / "task").glob("*.yaml")):
        target = config_yaml(path)["run"]["_target_"]
        if run is not None and target != run:
            continue
        module = importlib.import_module(target.rpartition(".")[0])
        found = [
            kind
            for kind in vars(module).values()
            if isinstance(kind, type)
            and issubclass(kind, TaskSettings)
            and kind.__module__ == module.__name__
        ]
        if len(found) != 1:
            raise TypeError(
                f"{module.__name__} (run target of {path}) defines {len(found)} TaskSettings "
                "subclasses; a task module defines exactly one, its schema"
            )
        (settings,) = found
        out[f"task/{path.stem}"] = settings
    return out


def config_yaml(path: Path) -> dict[str, Any]:
    """A config file's plain content (libyaml's parser: a tenth of OmegaConf.load's time, which
    counts when every file of the tree is read at each start)."""
    return yaml.load(path.read_text(), Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader)) or {}


@functools.cache
def referenced_schemas(conf_dir: Path = CONF_DIR) -> frozenset[str]:
    """Every `schema/<group>` path that a YAML file of the config tree lists in its defaults."""
    found = set()
    for path in conf_dir.rglob("*.yaml"):
        for entry in config_yaml(path).get("defaults", None) or []:
            text = entry if isinstance(entry, str) else next(iter(entry), "")
            if isinstance(text, str) and text.startswith("/schema/"):
                found.add(text.removeprefix("/").split("@")[0])
    return frozenset(found)


def _stored(store: ConfigStore, path: str) -> bool:
    *groups, name = path.split("/")
    node = store.repo
    for group in groups:
        node = node.get(group, {})
    return f"{name}.yaml" in node


def register_schemas(light: bool = False, run: str | None = None) -> None:
    """Store the root schema as `grace_schema` and each group's as `schema/<group>`.

    `light=True` stores the light schemas only, and an open placeholder (any keys, no types) for
    every other schema the configs refer to, so the config composes without torch or Lightning.
    `run` (a task config's `run._target_`) stores the schemas that task reads (heavy_schemas),
    and placeholders for the others.
    """
    register_simulator_schemas()
    store = ConfigStore.instance()
    store.store(name="grace_schema", node=RootConfig)
    groups: dict[str, Any] = light_schemas()
    if not light:
        with held_while_loading():
            groups |= heavy_schemas(run)
    if light or run is not None:
        open_paths = {p for p in referenced_schemas() if not _stored(store, p)}
        groups = {path.removeprefix("schema/"): {} for path in open_paths} | groups
    for path, node in groups.items():
        group, _, name = f"schema/{path}".rpartition("/")
        store.store(group=group, name=name, node=node)
