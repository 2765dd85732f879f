"""The root `threads` follows a task's own default (one thread for the planning tasks, whose
scoring batches are small) unless the command line gives it (docs/planning.md, "Threads")."""

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra

from grace import CONF_DIR
from grace.cli.schemas import register_schemas


def _threads(*overrides: str) -> int:
    register_schemas()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(config_name="config", overrides=["ckpt=x", "assembly=y", *overrides])
    return cfg.threads


@pytest.mark.parametrize(
    ("overrides", "threads"),
    [
        (("task=plan",), 1),
        (("task=train",), 2),
        (("task=plan", "threads=2"), 2),
    ],
)
def test_threads_follow_the_task_unless_given(overrides, threads):
    assert _threads(*overrides) == threads
