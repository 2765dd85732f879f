"""Which config keys change what, read from the schemas' declarations (grace/roles.py).

Every schema sits at a config key (its mount): `model` at `model`, `callbacks/early_stopping`
at `callbacks.early_stopping`, each task's at `task`. Walking the schemas from their mounts gives
the role of every declared key; a key below a declared one (a nested dataclass declared whole,
an untyped dict) has its role. grace/cli/fit.py compares a kept run's config with a new one
without the keys of the roles that may differ.
"""

from __future__ import annotations

import dataclasses
import functools
import typing
from collections.abc import Iterator, Mapping
from pathlib import Path

from grace import CONF_DIR
from grace.roles import Role, role_of

Schemas = Mapping[str, type]
"""`<group>/<name>` of a schema (as Hydra's ConfigStore holds it under `schema/`) → schema."""


def _join(*parts: str) -> str:
    return ".".join(p for p in parts if p)


def config_package(path: Path, conf_dir: Path = CONF_DIR) -> str:
    """The config key a YAML file of the config tree sits at (its group, or its @package)."""
    first = path.read_text().splitlines()[:1]
    if first and first[0].startswith("# @package"):
        package = first[0].split()[-1]
        return "" if package == "_global_" else package
    return ".".join(path.relative_to(conf_dir).parent.parts)


@functools.cache
def schema_mounts(conf_dir: Path = CONF_DIR) -> dict[str, str]:
    """`<group>/<name>` of each schema → the config key its node sits at, read from the YAML
    files that extend it (`- /schema/<group>/<name>@<package>`)."""
    from grace.cli.schemas import config_yaml

    found = {}
    for path in conf_dir.rglob("*.yaml"):
        for entry in config_yaml(path).get("defaults", None) or []:
            if isinstance(entry, str) and entry.startswith("/schema/"):
                schema, _, package = entry.removeprefix("/schema/").partition("@")
                package = "" if package == "_here_" else package
                found[schema] = _join(config_package(path, conf_dir), package)
    return found


def _fields(kind: type, prefix: str) -> Iterator[tuple[str, Role | None]]:
    """(config key, declared role) of `kind`'s fields; a nested dataclass that declares no
    role is walked into."""
    hints = typing.get_type_hints(kind)
    for spec in dataclasses.fields(kind):
        key, hint, role = _join(prefix, spec.name), hints[spec.name], role_of(spec)
        if role is None and isinstance(hint, type) and dataclasses.is_dataclass(hint):
            yield from _fields(hint, key)
        else:
            yield key, role


def _covered(key: str, declared: Mapping[str, Role]) -> bool:
    parts = key.split(".")
    return any(".".join(parts[:n]) in declared for n in range(1, len(parts) + 1))


def declared_roles(schemas: Schemas, root: type) -> tuple[dict[str, Role], list[str]]:
    """(config key → declared role, the keys no declaration covers), walking `root` (the root
    config's schema) and each of `schemas` from its mount. A key declared with two roles (by
    two schemas of one group) is a TypeError. `root`'s untyped slots where a group's schemas sit
    need no role of their own."""
    mounts = schema_mounts()
    found: list[tuple[str, Role | None]] = list(_fields(root, ""))
    for path, kind in schemas.items():
        found += _fields(kind, mounts[path])
    declared: dict[str, Role] = {}
    for key, role in found:
        if role is not None and declared.setdefault(key, role) is not role:
            raise TypeError(f"{key} is declared both {declared[key].value} and {role.value}")
    slots = {_join(*m.split(".")[:n]) for m in mounts.values() for n in range(1, m.count(".") + 2)}
    missing = sorted(
        {key for key, role in found if role is None and key not in slots}
        - {key for key, _ in found if _covered(key, declared)}
    )
    return declared, missing


@functools.cache
def run_roles(run: str | None) -> dict[str, Role]:
    """The declared roles of a run of the task whose `run._target_` is `run` (None: no task's
    own keys): the root config, every group's schemas, that task's settings. A group the task
    does not read (its settings' `reads`, grace/cli/runner.py) cannot change its results: its
    key is `run` for that task (task=experiment re-plans a kept run whatever `planner.*` says,
    since only self-training labels with the planner)."""
    from grace.cli.schemas import GROUP_SCHEMAS, RootConfig, light_schemas, task_schemas
    from grace.simulation.cell_config import simulator_schemas

    groups = {group: build() for group, build in GROUP_SCHEMAS.items()}
    schemas = light_schemas() | simulator_schemas()
    for built in groups.values():
        schemas |= built
    task = task_schemas(run=run) if run is not None else {}
    roles = declared_roles(schemas | task, RootConfig)[0]
    reads = next(iter(task.values())).reads if task else None
    if reads is not None:
        mounts = schema_mounts()
        for group in groups.keys() - set(reads):
            roles |= {mounts[path]: Role.run for path in groups[group]}
    return roles


def keys_of(run: str | None, *roles: Role) -> tuple[str, ...]:
    """The declared keys of a run of task `run` (see run_roles) whose role is one of `roles`."""
    return tuple(sorted(k for k, role in run_roles(run).items() if role in roles))


EXPERIMENT_RUN = "grace.tasks.experiment.run"
"""The `run._target_` of task=experiment, whose runs write the results.json files that
task=gather and task=report read."""


def experiment_run_keys() -> tuple[str, ...]:
    """The `run` keys of an experiment: overriding them changes how a run ran (threads, paths),
    never what it measured, so a run that differs only in them is no variant."""
    return keys_of(EXPERIMENT_RUN, Role.run)
