"""`python -m grace task=compare_simulators [overrides…]`: what the robot and the second arm add.

Labels the same generated frames with each simulator of grace.data.stats.SIMULATORS (generated,
or read from the cache, like `task=generate`): the run's config is composed again with each
`simulator=<name>`, every other override kept. Writes their assembly-by-assembly comparison
(grace.data.stats.simulator_comparison) to simulators.json in the run folder, and the same as a
markdown table to simulators.md (the simulator table of docs/world.md, with `scale=default`).
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
from grace.data.atomic import write_json_atomic, write_text_atomic
from grace.data.stats import SIMULATORS, simulator_comparison
from grace.domain.sample import LabelledAssembly
from grace.evaluation.tables import markdown_table


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
    comparison = simulator_comparison(labelled)
    out = Path(cfg.paths.output_dir)
    write_json_atomic(out / "simulators.json", comparison)
    table = comparison_table(comparison)
    write_text_atomic(out / "simulators.md", table + "\n")
    print(table)


def comparison_table(comparison: dict[str, dict]) -> str:
    """One row per size: infeasible shares per simulator, what the robot and second arm change."""
    head = ["size", "assemblies", *(f"infeasible {n}" for n in SIMULATORS)]
    head += ["labels ≠ boxes", "labels ≠ single_arm", "feasible only with two arms"]
    rows = [
        [
            f"A{size}",
            str(c["assemblies"]),
            *(f"{c['infeasible_fraction'][n]:.3f}" for n in SIMULATORS),
            f"{c['labels_changed_vs_boxes']:.3f}",
            f"{c['labels_changed_vs_single_arm']:.3f}",
            f"{c['feasible_only_with_two_arms']:.3f}",
        ]
        for size, c in comparison.items()
    ]
    return markdown_table(head, rows)
