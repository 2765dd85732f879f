"""GRACE: learning robotic assembly sequence planning (Atad, Feng et al., IROS 2023)."""

from pathlib import Path

CONF_DIR = Path(__file__).resolve().parent / "conf"
"""The Hydra config tree shipped inside the package (one folder per config group)."""
