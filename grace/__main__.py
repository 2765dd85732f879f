"""Entry point: `python -m grace task=<name> ...` (or `grace ...`) composes the config and runs one
task. The configs ship inside the package (grace/conf), so this works from any folder."""

import sys

import hydra
from omegaconf import DictConfig

from grace import CONF_DIR
from grace.errors import UserError
from grace.tasks.runner import run_task
from grace.tasks.schemas import register_schemas

register_schemas()


# An absolute path: found whether this module runs as __main__ or from the console script.
@hydra.main(version_base="1.3", config_path=str(CONF_DIR), config_name="config")
def main(cfg: DictConfig) -> float | None:
    try:
        return run_task(cfg)
    except UserError as e:  # the message is the whole report (grace/errors.py)
        print(f"error: {e}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
