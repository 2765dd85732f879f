"""Every numeric field of every config schema has a declared range (grace/cli/ranges.py), every
range names a key the config has, the shipped configs lie inside their ranges, and a value
outside is one line naming the key, the range and a fix that lies inside it."""

import dataclasses
import math
import types
import typing
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from grace import CONF_DIR
from grace.cli.key_roles import config_package, schema_mounts
from grace.cli.ranges import RANGES, SEED_MAX, Range
from grace.cli.schemas import RootConfig, heavy_schemas, light_schemas
from grace.cli.values import check_ranges
from grace.errors import UserError
from grace.simulation.cell_config import CellConfig, GeneratorConfig, SimulatorConfig


def _join(*parts: str) -> str:
    return ".".join(p for p in parts if p)


def _numeric(hint: object) -> bool:
    """int or float, optional or in a list (bool is no number here)."""
    if hint in (int, float):
        return True
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (types.UnionType, typing.Union):
        return any(_numeric(a) for a in args if a is not type(None))
    return origin is list and len(args) == 1 and _numeric(args[0])


def numeric_keys(kind: type, prefix: str) -> set[str]:
    """The config keys of `kind`'s numeric fields, nested dataclasses included."""
    hints = typing.get_type_hints(kind)
    keys = set()
    for spec in dataclasses.fields(kind):
        hint, key = hints[spec.name], _join(prefix, spec.name)
        if isinstance(hint, type) and dataclasses.is_dataclass(hint):
            keys |= numeric_keys(hint, key)
        elif _numeric(hint):
            keys.add(key)
    return keys


def schema_keys() -> set[str]:
    """The config key of every numeric field of every schema the config is checked with."""
    mounts = schema_mounts()
    schemas = light_schemas() | heavy_schemas()
    simulator = {
        "simulator": SimulatorConfig,
        "simulator/cell": CellConfig,
        "simulator/generator": GeneratorConfig,
    }
    keys = numeric_keys(RootConfig, "")
    for path, kind in (schemas | simulator).items():
        keys |= numeric_keys(kind, mounts[path])
    return keys


def yaml_numbers() -> dict[str, list[tuple[Path, object]]]:
    """Config key → the numbers (or lists of numbers) the shipped YAML files give it."""
    out: dict[str, list[tuple[Path, object]]] = {}

    def walk(node: object, key: str, path: Path) -> None:
        if isinstance(node, dict):
            for name, value in node.items():
                if name != "defaults":
                    walk(value, _join(key, str(name)), path)
        elif isinstance(node, int | float | list) and not isinstance(node, bool):
            items = node if isinstance(node, list) else [node]
            if items and all(isinstance(v, int | float) and not isinstance(v, bool) for v in items):
                out.setdefault(key, []).append((path, node))

    for path in CONF_DIR.rglob("*.yaml"):
        walk(OmegaConf.to_container(OmegaConf.load(path)), config_package(path), path)
    return out


def test_every_numeric_schema_field_has_a_range():
    missing = sorted(schema_keys() - set(RANGES))
    assert not missing, f"numeric config keys without a range in grace/cli/ranges.py: {missing}"


def test_every_range_names_a_numeric_key_of_the_config():
    known = schema_keys() | set(yaml_numbers())
    assert not sorted(set(RANGES) - known)


def test_the_shipped_configs_lie_in_their_ranges():
    outside = [
        f"{path.relative_to(CONF_DIR)}: {key}={value}"
        for key, found in yaml_numbers().items()
        if key in RANGES
        for path, value in found
        if not all(RANGES[key].holds(v) for v in (value if isinstance(value, list) else [value]))
    ]
    assert not outside


def test_each_range_says_why_and_proposes_a_value_inside_it():
    for key, bound in RANGES.items():
        assert bound.why, key
        assert bound.holds(bound.suggestion()), key


def test_a_range_holds_its_ends_as_declared():
    seed, rate = RANGES["seed"], RANGES["model.optimizer.lr"]
    assert seed.holds(0) and seed.holds(SEED_MAX) and not seed.holds(SEED_MAX + 1)
    assert not seed.holds(-1) and not seed.holds(math.nan)
    assert not rate.holds(0) and rate.holds(1e-9) and rate.interval() == "(0, ∞)"
    steps = RANGES["trainer.max_steps"]
    assert steps.holds(-1) and not steps.holds(0) and steps.interval() == "[1, ∞) or -1"
    assert Range(0, 0.5, "x", open_high=True).interval() == "[0, 0.5)"


@pytest.mark.parametrize(
    ("values", "message"),
    [
        (
            {"seed": 2**32},
            "seed=4294967296 is outside [0, 4294967295]; fix: seed=0 (",
        ),
        (
            {"trainer": {"max_steps": 0}},
            "trainer.max_steps=0 is outside [1, ∞) or -1; fix: trainer.max_steps=1 (",
        ),
        (
            {"task": {"ks": [0, 1, 3]}},
            "task.ks=[0, 1, 3]: 0 is outside [1, ∞); fix: task.ks=[1,3] (",
        ),
        (
            {"model": {"optimizer": {"lr": -1}}},
            "model.optimizer.lr=-1 is outside (0, ∞); fix: model.optimizer.lr=0.0022 (",
        ),
    ],
)
def test_a_value_outside_its_range_is_one_line_with_a_fix_inside_it(values, message):
    with pytest.raises(UserError) as raised:
        check_ranges(OmegaConf.create(values))
    assert str(raised.value).startswith(message)
    assert "\n" not in str(raised.value)


def test_values_inside_their_ranges_and_what_is_no_number_pass():
    check_ranges(
        OmegaConf.create(
            {
                "seed": SEED_MAX,
                "trainer": {"max_steps": -1, "max_epochs": None},
                "task": {"ks": [1, 2], "sizes": {3: 4}},  # search_bench: a mapping
                "tune": {"folds": "${oops}"},  # unresolvable: the compose names it
            }
        )
    )
