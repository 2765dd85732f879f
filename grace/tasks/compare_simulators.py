"""`python -m grace task=compare_simulators [overrides…]`: what the robot and the second arm add.

Labels the same generated frames with each simulator of grace.data.stats.SIMULATORS (generated,
or read from the cache, like `task=generate`): the run's config is composed again with each
`simulator=<name>`, every other override kept. Writes their assembly-by-assembly comparison
(grace.data.stats.simulator_comparison) to simulators.json in the run folder and prints it, e.g.
with `scale=default` for the simulator table of the documentation.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.utils import instantiate
from omegaconf import DictConfig

from grace import CONF_DIR
from grace.cli.runner import TaskSettings, task_overrides
from grace.data.atomic import strict_json, write_text_atomic
from grace.data.stats import SIMULATORS, simulator_comparison
from grace.domain.sample import LabelledAssembly


@dataclass
class CompareSimulatorsSettings(TaskSettings):
    """Schema of `task=compare_simulators` (grace/conf/task/compare_simulators.yaml)."""


def labelled_by(simulator: str, overrides: list[str]) -> list[LabelledAssembly]:
    """The data set of the config `overrides` + `simulator=<simulator>`, loaded."""
    overrides = [*overrides, f"simulator={simulator}"]
    if GlobalHydra.instance().is_initialized():  # inside a Hydra run
        cfg = compose("config", overrides=overrides)
    else:
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            cfg = compose("config", overrides=overrides)
    return instantiate(cfg.dataset).load()


def run(cfg: DictConfig) -> None:
    """Label the data set's frames with every simulator; write and print the comparison."""
    overrides = task_overrides()
    labelled = {name: labelled_by(name, overrides) for name in SIMULATORS}
    text = strict_json(simulator_comparison(labelled))
    write_text_atomic(Path(cfg.paths.output_dir) / "simulators.json", text + "\n")
    print(text)
