"""A labelled assembly: what the simulator produces and every later stage consumes."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from grace.domain.assembly import Assembly
from grace.domain.orders import GroundTruth


@dataclass(eq=False)
class LabelledAssembly:
    """An assembly with its ground truth and the simulator's diagnostics.

    `info` holds JSON-serialisable facts about how the truth came about, e.g. `cause`
    ("reach" | "collision" | "other" | None), `robot_pruned`, `nonlocal_block`, `seconds`.

    `known` is for a partial label (a search's, grace/planning/self_labels.py): per state of
    the truth, the parts whose next-step label is known (a bitmask); training puts no loss on
    the others. None: every label is known, as in a brute force's truth.
    """

    assembly: Assembly
    truth: GroundTruth
    info: dict[str, Any] = field(default_factory=dict)
    known: dict[int, int] | None = None

    @property
    def size(self) -> int:
        return self.assembly.n_parts

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, LabelledAssembly)
            and self.assembly == other.assembly
            and self.truth == other.truth
            and self.info == other.info
            and self.known == other.known
        )
