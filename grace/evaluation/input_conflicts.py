"""How far the Assembly Graph's input decides the step labels: states whose network input is
identical while their labels differ (docs/information-ceiling.md).

A step is one state (the placed set) and one candidate part, as the network scores it: the
assembly's encoded tensors (paper Sec. IV-B; grace/graphs/assembly_graph.py, `AssemblyTensors`,
which both of the network's paths read, padded or per state), the assembled flags of the state and
the candidate's index. Two steps with equal inputs get equal scores from any network, so where
their labels (valid next step or not) differ, no network can be right on both: on a set of steps,
the best any function of the input reaches is the share of steps that carry the majority label
of their input (the Bayes ceiling of that set's empirical distribution).

Tensors are compared byte for byte (float32 as the network gets them), not rounded.

The graph holds the assembly's relative geometry only, so the same assembly moved on the table
has the same input, while the cell (the arms' reach and links) may label it otherwise:
:func:`move_conflicts` relabels moved copies with the simulator and counts the steps whose label
the move changes, conflicts that a data set drawn without such copies never shows.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import Assembly, Part
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.graphs.assembly_graph import AssemblyTensors, encode_assembly
from grace.graphs.datamodule import StateSet, state_masks, training_states
from grace.graphs.encoding import GraphEncoding

_PART_BITS = 5  # candidate index: parts below 32 (the simulator's max_parts is 20)
_STATE_BITS = 32  # placed-set bitmask


def tensors_digest(tensors: AssemblyTensors) -> bytes:
    """A digest of every state-independent tensor the network reads, byte for byte (shapes
    included, so equal bytes of different shapes differ)."""
    digest = hashlib.sha256()
    for x in (
        tensors.part_static,
        tensors.surface_x,
        tensors.relation,
        tensors.surface_part,
        tensors.pair_geometry,
    ):
        array = x.detach().cpu().contiguous().numpy()
        digest.update(f"{array.dtype}{array.shape}".encode())
        digest.update(array.tobytes())
    return digest.digest()


@dataclass(frozen=True)
class Steps:
    """Steps as (input key, label) rows: `key` equal iff the network input is equal."""

    key: np.ndarray  # (K,) int64
    label: np.ndarray  # (K,) bool: the candidate is a valid next step

    @classmethod
    def concat(cls, parts: Sequence[Steps]) -> Steps:
        return cls(
            np.concatenate([p.key for p in parts] or [np.zeros(0, np.int64)]),
            np.concatenate([p.label for p in parts] or [np.zeros(0, bool)]),
        )

    def __len__(self) -> int:
        return len(self.key)


class InputKeys:
    """Numbers assemblies by their encoded input (equal tensors, one number) and builds the
    step rows of their states."""

    def __init__(self, enc: GraphEncoding) -> None:
        if enc.randomised:
            raise UserError(
                "model.graph: a randomised encoding (random PE or permuted ids) draws its inputs "
                "per use, so equal inputs cannot be counted; fix: pe=sinusoidal|none, "
                "permute_*=never"
            )
        self.enc = enc
        self._ids: dict[bytes, int] = {}

    def input_id(self, sample: LabelledAssembly) -> int:
        """The number of `sample`'s encoded input (the same for assemblies encoded alike)."""
        digest = tensors_digest(encode_assembly(sample.assembly, self.enc))
        return self._ids.setdefault(digest, len(self._ids))

    def steps(self, sample: LabelledAssembly, states: np.ndarray, valid: np.ndarray) -> Steps:
        """Rows of every unplaced candidate of `states` (bitmasks) with its label from `valid`
        (bitmasks of the valid next parts)."""
        n = sample.size
        states = np.asarray(states, dtype=np.int64)
        parts = np.arange(n, dtype=np.int64)
        unplaced = ((states[:, None] >> parts) & 1) == 0
        label = ((np.asarray(valid, dtype=np.int64)[:, None] >> parts) & 1) == 1
        key = (self.input_id(sample) << (_STATE_BITS + _PART_BITS)) | (
            (states[:, None] << _PART_BITS) | parts
        )
        return Steps(key[unplaced], label[unplaced])

    def training_steps(self, sample: LabelledAssembly, states: StateSet | str) -> Steps:
        """The steps of `sample` that the network trains on (`datamodule.states`)."""
        return self.steps(sample, *training_states(sample, states))


def _groups(steps: Steps) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(distinct keys, valid count, invalid count) per key."""
    keys, inverse = np.unique(steps.key, return_inverse=True)
    valid = np.bincount(inverse, weights=steps.label, minlength=len(keys)).astype(np.int64)
    total = np.bincount(inverse, minlength=len(keys))
    return keys, valid, total - valid


def within(steps: Steps) -> dict[str, float]:
    """Equal inputs within one set (counts): steps sharing their input with another step, steps
    whose input also carries the other label, and the steps the Bayes ceiling gets right (each
    input predicted as its majority label), overall and among those with the other label."""
    _, valid, invalid = _groups(steps)
    total = valid + invalid
    mixed = (valid > 0) & (invalid > 0)
    majority = np.maximum(valid, invalid)
    return {
        "steps": len(steps),
        "shared_input": int(total[total > 1].sum()),
        "label_conflicts": int(total[mixed].sum()),
        "ceiling_hits": int(majority.sum()),
        "ceiling_hits_on_conflicts": int(majority[mixed].sum()),
    }


def against_training(train: Steps, test: Steps) -> dict[str, float]:
    """Test steps (counts): whose input a training step has, those with a training step of the
    other label, and the test steps the Bayes ceiling gets right, overall and among those with
    the other label; the ceiling predicts each input as the majority label of the training and
    test steps that hold it (a tie scores ½, the expected score of either choice)."""
    keys, valid, invalid = _groups(Steps.concat([train, test]))
    seen_keys, seen_valid, seen_invalid = _groups(train)
    if len(seen_keys) == 0:
        seen = other = np.zeros(len(test), dtype=bool)
    else:
        where = np.clip(np.searchsorted(seen_keys, test.key), 0, len(seen_keys) - 1)
        seen = seen_keys[where] == test.key
        other = seen & np.where(test.label, seen_invalid[where] > 0, seen_valid[where] > 0)
    pooled = np.searchsorted(keys, test.key)
    own = np.where(test.label, valid[pooled], invalid[pooled])
    others = np.where(test.label, invalid[pooled], valid[pooled])
    right = (own > others) + 0.5 * (own == others)
    return {
        "steps": len(test),
        "seen_in_training": int(seen.sum()),
        "label_conflicts": int(other.sum()),
        "ceiling_hits": float(right.sum()),
        "ceiling_hits_on_conflicts": float(right[other].sum()),
    }


def add_counts(counts: Sequence[dict[str, float]]) -> dict[str, float]:
    """Counts of several sets (folds) summed, with the Bayes ceilings as shares: `ceiling` over
    all steps, `ceiling_on_conflicts` over the steps with the other label (1 when none)."""
    out: dict[str, float] = {}
    for c in counts:
        for name, value in c.items():
            out[name] = out.get(name, 0) + value
    steps, conflicts = out.get("steps", 0), out.get("label_conflicts", 0)
    out["ceiling"] = out.get("ceiling_hits", 0) / steps if steps else 1.0
    out["ceiling_on_conflicts"] = (
        out.get("ceiling_hits_on_conflicts", 0) / conflicts if conflicts else 1.0
    )
    return out


def moved(assembly: Assembly, dx: float, dy: float) -> Assembly:
    """`assembly` moved by (dx, dy) mm on the table: the same relative geometry elsewhere in
    the cell."""
    parts = []
    for part in assembly.parts:
        pose = part.pose.copy()
        pose[:2, 3] += (dx, dy)
        parts.append(Part(part.name, part.type, pose))
    return Assembly(tuple(parts), assembly.name)


def move_conflicts(
    keys: InputKeys,
    sample: LabelledAssembly,
    label: Callable[[Assembly], LabelledAssembly],
    moves: Sequence[Sequence[float]],
    states: StateSet | str,
) -> dict[str, float]:
    """Counts over copies of `sample` moved by each of `moves` and labelled by `label` (the
    simulator): copies whose input equals the original's (the graph holds relative geometry
    only), and on those, the steps of either's training states (`states`) with the same input
    and another label, the equal-input steps compared, and the copies whose feasibility differs."""
    out = {"moved": 0, "same_input": 0, "steps": 0, "label_changes": 0, "feasibility_flips": 0}
    for dx, dy in moves:
        copy = label(moved(sample.assembly, dx, dy))
        out["moved"] += 1
        if keys.input_id(copy) != keys.input_id(sample):
            continue
        chosen = np.union1d(training_states(sample, states)[0], training_states(copy, states)[0])
        before = keys.steps(sample, chosen, state_masks(sample.truth, chosen)[0])
        after = keys.steps(copy, chosen, state_masks(copy.truth, chosen)[0])
        out["same_input"] += 1
        out["steps"] += len(before)
        out["label_changes"] += int((before.label != after.label).sum())
        out["feasibility_flips"] += int(sample.truth.feasible != copy.truth.feasible)
    return out
