"""Entry point: `python -m grace task=<name> ...` composes the config and runs one task."""

import hydra
from omegaconf import DictConfig

from grace.tasks.runner import run_task


@hydra.main(version_base="1.3", config_path="conf", config_name="config")
def main(cfg: DictConfig) -> float | None:
    return run_task(cfg)


if __name__ == "__main__":
    main()
