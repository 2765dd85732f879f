"""What a config key changes, declared beside the key's schema field (docs/contributing.md,
"What a config key changes").

A kept run is compared with a new config key by key: a rerun resumes a killed run only if every
key that decides the results agrees (grace/cli/fit.py, resume_from), and `task.checkpoints`
re-plans a kept model only if every key that decides the weights agrees (kept_module). Each
field of a config schema says which kind of key it is, so a new key is a decision, not a silent
"this retrains". A leaf with no declaration fails tests/cli/test_key_roles.py.
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Mapping
from types import MappingProxyType


class Role(enum.Enum):
    """What changing a config key changes."""

    weights = "weights"
    """The trained weights (or the data and split they are trained on): a rerun retrains."""
    planning = "planning"
    """How a trained model plans and is measured, never its weights: a kept checkpoint is
    re-planned under new values (`task.checkpoints`)."""
    run = "run"
    """Where or how fast a run goes, never its results: a rerun may change it and resume."""


ROLE = "role"
"""The dataclass field metadata key that holds a field's Role."""

WEIGHTS: Mapping[str, Role] = MappingProxyType({ROLE: Role.weights})
PLANNING: Mapping[str, Role] = MappingProxyType({ROLE: Role.planning})
RUN: Mapping[str, Role] = MappingProxyType({ROLE: Role.run})
"""Field metadata declaring a role: `threads: int = field(default=2, metadata=RUN)`. On a nested
dataclass it declares the role of every key below it."""


def role_of(spec: dataclasses.Field) -> Role | None:
    """The role a schema field declares, None if it declares none."""
    return spec.metadata.get(ROLE)
