"""Every field of every config schema declares what it changes (grace/roles.py), a declaration
names a key the schema has, and the keys a kept run may differ in are the ones they were before
the roles were declared (grace/cli/fit.py: resume_from, kept_module)."""

from dataclasses import dataclass, field

import pytest

from grace.cli.key_roles import declared_roles, keys_of, schema_mounts
from grace.cli.schemas import GROUP_SCHEMAS, RootConfig, light_schemas, schema, task_schemas
from grace.roles import PLANNING, RUN, Role
from grace.simulation.cell_config import simulator_schemas

RUN_KEYS = {
    *("threads", "debug", "trainer.enable_progress_bar", "dataset.workers", "dataset.data_dir"),
    *("paths.data_dir", "paths.output_dir", "paths.fit_dir", "paths.log_file"),
}
"""Where or how fast a run goes: the keys a rerun could change before the roles were declared."""
PLANNING_KEYS = {
    *("model.net.score", "classifier", "threshold._target_", "threshold.floor", "threshold.level"),
}
"""How a kept model plans: the keys `task.checkpoints` could change before (every task)."""
EXPERIMENT_PLANNING = {
    *("task.checkpoints", "task.scorer", "task.threshold", "task.ks", "task.baselines"),
    "task.recording",
}

UNREAD = {"planner", "tune"}
"""The groups a cross-validated experiment never reads: they cannot change its results."""


def group_schemas() -> dict[str, type]:
    out = light_schemas() | simulator_schemas()
    for build in GROUP_SCHEMAS.values():
        out |= build()
    return out


TASKS = sorted(task_schemas())


@pytest.mark.parametrize("task", TASKS)
def test_every_schema_field_declares_its_role(task):
    schemas = group_schemas() | {task: task_schemas()[task]}
    _, missing = declared_roles(schemas, RootConfig)
    assert not missing, f"config keys without a role (grace/roles.py) under {task}: {missing}"


def test_every_schema_sits_at_a_config_key():
    assert set(group_schemas()) | set(task_schemas()) <= set(schema_mounts())


def test_a_declaration_must_name_a_key_of_the_schema():
    def target(a: int = 1, b: int = 2) -> None: ...

    kind = schema(target, role=Role.weights, roles={"b": Role.run})
    assert {f.name: f.metadata["role"] for f in kind.__dataclass_fields__.values()} == {
        "_target_": Role.weights,
        "a": Role.weights,
        "b": Role.run,
    }
    with pytest.raises(TypeError, match=r"name no key of its schema: \['c'\]"):
        schema(target, role=Role.weights, roles={"c": Role.run})


def test_a_field_without_a_role_is_named():
    @dataclass
    class Undeclared:
        x: int = 0
        y: int = field(default=0, metadata=RUN)

    assert declared_roles({"task/experiment": Undeclared}, RootConfig)[1] == ["task.x"]


def test_one_key_declared_with_two_roles_is_an_error():
    @dataclass
    class One:
        x: int = field(default=0, metadata=RUN)

    @dataclass
    class Other:
        x: int = field(default=0, metadata=PLANNING)

    with pytest.raises(TypeError, match=r"task\.x is declared both run and planning"):
        declared_roles({"task/experiment": One, "task/train": Other}, RootConfig)


@pytest.mark.parametrize(
    ("run", "run_keys", "planning_keys"),
    [
        ("grace.tasks.experiment.run", {"task.fold_jobs", *UNREAD}, EXPERIMENT_PLANNING),
        (
            "grace.tasks.feasibility.run",
            {"task.fold_jobs", *UNREAD},
            EXPERIMENT_PLANNING | {"task.classifiers", "task.densities"},
        ),
        ("grace.tasks.train.run", set(), set()),
        ("grace.tasks.tune.run", set(), set()),
    ],
)
def test_the_training_tasks_keep_the_roles_their_keys_had(run, run_keys, planning_keys):
    assert set(keys_of(run, Role.run)) == RUN_KEYS | run_keys
    assert set(keys_of(run, Role.planning)) == PLANNING_KEYS | planning_keys


def test_only_a_task_that_labels_with_the_planner_retrains_when_it_changes():
    """Self-training labels its draws with the verified search: its planner decides the weights;
    an experiment never reads the planner, so its keys cannot change an experiment's results."""
    assert "planner" not in keys_of("grace.tasks.self_train.run", Role.run, Role.planning)
    assert "planner" in keys_of("grace.tasks.experiment.run", Role.run)
