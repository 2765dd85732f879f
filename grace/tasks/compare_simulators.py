"""`python -m grace.tasks.compare_simulators [overrides…]`: what the robot and the second arm add.

Labels the same generated frames with each simulator of grace.data.stats.SIMULATORS (generated,
or read from the cache, like `task=generate`) and prints their assembly-by-assembly comparison
(grace.data.stats.simulator_comparison) as JSON, e.g. with `scale=default` for README's table.
"""

from __future__ import annotations

import sys

from hydra import compose, initialize_config_dir
from hydra.utils import instantiate

from grace import CONF_DIR
from grace.data.atomic import strict_json
from grace.data.stats import SIMULATORS, simulator_comparison
from grace.tasks.schemas import register_schemas


def main() -> None:
    register_schemas()
    labelled = {}
    for name in SIMULATORS:
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base=None):
            cfg = compose("config", overrides=[*sys.argv[1:], f"simulator={name}"])
        labelled[name] = instantiate(cfg.dataset).load()
    print(strict_json(simulator_comparison(labelled)))


if __name__ == "__main__":
    main()
