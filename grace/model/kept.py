"""The files a training run keeps: its best checkpoint and its resolved config, found and read
without torch, so the command line checks `ckpt=` before the run starts (grace/cli/checks.py).

A training run keeps its resolved config (`config.yaml`, KEPT_CONFIG) in its folder beside
`checkpoints/` (grace/cli/fit.py); the model is rebuilt from it (grace/model/checkpoints.py).
"""

from __future__ import annotations

import copy
import functools
from pathlib import Path

import yaml
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from grace.errors import UserError

KEPT_CONFIG = "config.yaml"
"""The resolved config of a training run, kept in its folder beside `checkpoints/` so that the
model can be rebuilt later (task=plan)."""

CHECKPOINT = Path("checkpoints") / "best.ckpt"
"""The best checkpoint of a training run, under its folder."""

KEPT_KEYS = ("model", "simulator")
"""What a kept config must hold to rebuild the model and the cell it was trained in."""


def find_checkpoint(path: str | Path, fold: int = 0) -> Path:
    """The checkpoint `path` names: a .ckpt file, a train run folder or an experiment run folder
    (its `fold_<fold>`)."""
    path = Path(path)
    candidates = [path] if path.suffix == ".ckpt" else [path / CHECKPOINT]
    candidates.append(path / f"fold_{fold}" / CHECKPOINT)
    found = next((c for c in candidates if c.is_file()), None)
    if found is None:
        raise UserError(
            f"ckpt={path}: no checkpoint there (looked for {', '.join(map(str, candidates))}); "
            "fix: pass a .ckpt file or the folder of a train or experiment run"
        )
    return found


def kept_config(ckpt: Path) -> tuple[Path, DictConfig]:
    """The config kept by the run that wrote `ckpt` (beside its `checkpoints/`), and where."""
    kept = ckpt.parent.parent / KEPT_CONFIG
    if not kept.is_file():
        raise UserError(
            f"ckpt={ckpt}: no {KEPT_CONFIG} beside it ({kept}); fix: use a checkpoint of a run "
            f"that kept its config (every train and experiment run writes one)"
        )
    return kept, read_kept_config(kept)


def read_kept_config(path: Path, keys: tuple[str, ...] = KEPT_KEYS) -> DictConfig:
    """The config kept at `path`; a UserError naming the file (and line) when it is not a
    readable YAML mapping holding `keys`."""
    fix = (
        f"fix: use a run folder whose {KEPT_CONFIG} is intact (each train and experiment "
        "run writes one beside its checkpoints), or train again"
    )
    try:
        cfg = copy.deepcopy(_parsed(Path(path).read_text(encoding="utf-8")))
    except OSError as error:
        raise UserError(f"{path}: unreadable ({error.strerror}); {fix}") from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        reason = getattr(error, "problem", None) or type(error).__name__
        raise UserError(f"{where}: not valid YAML ({reason}); {fix}") from None
    except OmegaConfBaseException as error:
        raise UserError(f"{path}: not a config ({str(error).splitlines()[0]}); {fix}") from None
    if not isinstance(cfg, DictConfig):
        raise UserError(f"{path}: not a kept run config (a list, not a mapping); {fix}")
    missing = [k for k in keys if not OmegaConf.is_dict(cfg.get(k))]
    if missing:
        raise UserError(f"{path}: not a kept run config (no {', '.join(missing)}); {fix}")
    return cfg


@functools.lru_cache(maxsize=8)
def _parsed(text: str) -> object:
    """`text` as OmegaConf loads a YAML file, parsed once per content: a planning process reads
    its kept config three times (preflight, checks, model), and parsing is most of the cost
    (0.1–0.25 s each); callers get deep copies, which they may change."""
    return OmegaConf.create(text)
