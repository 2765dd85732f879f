"""Whether files can be written into a folder, found without writing any: the run folder and the
data folder before a run (grace/cli/values.py), a data set's own folders before it is generated
(grace/data/store.py), so an unusable one stops the run in one line before any work, never in a
traceback halfway through it."""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Obstacle:
    """What stops files being written into a folder: `path` is a file in the folder's place or
    on its way (`reason` None), or the nearest existing folder, which refuses a new file
    (`reason`: the system's words, e.g. "Permission denied")."""

    path: Path
    reason: str | None = None

    @property
    def is_file(self) -> bool:
        return self.reason is None


def obstacle(folder: str | Path) -> Obstacle | None:
    """Why files cannot be written into `folder` (made with its parents when absent), or None.
    Writes nothing: the probe is an unnamed temporary file in the nearest existing folder."""
    folder = Path(folder).absolute()
    existing = next(p for p in (folder, *folder.parents) if p.exists())
    if not existing.is_dir():
        return Obstacle(existing)
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as error:
        return Obstacle(existing, error.strerror or type(error).__name__)
    return None
