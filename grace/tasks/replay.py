"""`python -m grace task=replay path=<run folder or .rrd>`: look at a recording.

Opens the `.rrd` in the rerun viewer when a display exists; always prints how to open it and a
summary of what it holds (assemblies, entities, timelines, failure entries), read back with
rerun's own reader (docs/recordings.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from omegaconf import MISSING, DictConfig

from grace.cli.runner import TaskSettings
from grace.errors import UserError
from grace.roles import RUN
from grace.visualisation.recording import open_viewer, summarise

RECORDINGS = ("sequences.rrd", "plan.rrd")


@dataclass
class ReplaySettings(TaskSettings):
    """Schema of `task=replay` (values in grace/conf/task/replay.yaml)."""

    # a run folder (sequences.rrd or plan.rrd in it) or a .rrd file
    path: str | None = field(default=MISSING, metadata=RUN)
    # open the viewer when a display exists
    viewer: bool = field(default=True, metadata=RUN)


def find_recording(path: str | Path) -> Path:
    """The `.rrd` that `path` names, or the recording in the run folder `path`."""
    path = Path(path)
    if path.is_file() and path.suffix == ".rrd":
        return path
    found = next((path / n for n in RECORDINGS if (path / n).is_file()), None)
    if found is None:
        raise UserError(
            f"path={path}: not a .rrd file nor a run folder holding {' or '.join(RECORDINGS)}; "
            "fix: pass the folder of an experiment or plan run, or its .rrd"
        )
    return found


def run(cfg: DictConfig) -> None:
    if not cfg.task.path:
        raise UserError("task=replay needs path=; fix: add path=<run folder or .rrd>")
    recording = find_recording(cfg.task.path)
    try:
        summary = summarise(recording)
    except Exception as e:  # rerun's reader names what is wrong with the file
        raise UserError(
            f"path={recording}: not a readable rerun recording ({e}); fix: pass a .rrd that "
            "task=experiment or task=plan wrote"
        ) from None
    print("\n".join(summary.lines()))
    if cfg.task.viewer and open_viewer(recording):
        print(f"opened {recording} in the rerun viewer")
    else:
        print(f"no display: open it on a machine with one with `rerun {recording}` (rerun-sdk)")
