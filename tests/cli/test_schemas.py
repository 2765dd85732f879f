import pytest

from grace import CONF_DIR
from grace.cli.schemas import heavy_schemas, task_schemas


def test_every_task_config_gets_the_settings_of_its_module_as_schema():
    schemas = task_schemas()
    assert set(schemas) == {f"task/{p.stem}" for p in (CONF_DIR / "task").glob("*.yaml")}
    assert schemas["task/experiment"].__name__ == "ExperimentSettings"
    # a subclass of the experiment's settings, picked from its own module only
    assert schemas["task/feasibility"].__name__ == "FeasibilitySettings"


def test_a_task_module_without_settings_is_named(tmp_path):
    (tmp_path / "task").mkdir()
    target = "run: {_target_: grace.evaluation.report.write_results, _partial_: true}\n"
    (tmp_path / "task" / "odd.yaml").write_text(target)
    with pytest.raises(TypeError, match=r"grace\.evaluation\.report .* defines 0 TaskSettings"):
        task_schemas(tmp_path)


def test_a_task_loads_the_schemas_of_the_groups_it_reads():
    """task=plan reads the planner group only: its run loads no Lightning schema; a task that
    names none (train) loads every group's."""
    assert set(heavy_schemas(run="grace.tasks.plan.run")) == {
        "task/plan", "planner/verified", "planner/topk",
    }  # fmt: skip
    train = heavy_schemas(run="grace.tasks.train.run")
    assert {"task/train", "model", "trainer", "planner/verified"} <= set(train)
    assert "task/plan" not in train
