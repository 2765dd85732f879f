"""GRACE: learning robotic assembly sequence planning (Atad, Feng et al., IROS 2023)."""

from pathlib import Path

CONF_DIR = Path(__file__).resolve().parent / "conf"
"""The Hydra config tree shipped inside the package (one folder per config group)."""


def _register_schemas() -> None:
    """Typed schemas the config tree extends (Hydra's ConfigStore); needed before any compose."""
    from grace.simulation.cell_config import register

    register()


_register_schemas()
