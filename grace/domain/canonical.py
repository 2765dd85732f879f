"""Canonical forms of labelled assemblies, to find copies in a data set (docs/protocols.md).

Two assemblies are the same when they hold the same part types at the same poses and have the
same ground truth. The generator draws assemblies independently, so a data set can hold copies:
exact ones (the same parts in the same numbering) and renumbered ones (the same parts listed in
another order, with the ground truth's bitmasks permuted to match). A copy in the training folds
of an assembly in the test fold is a test assembly seen in training; the fold split keeps every
group of copies in one fold (grace/evaluation/protocols.py).
"""

from __future__ import annotations

import hashlib

import numpy as np

from grace.domain.sample import LabelledAssembly

POSE_DECIMALS = 6
"""Poses are compared rounded to 1e-6 mm (and 1e-6 in the rotation), so that float noise of
the same construction does not tell copies apart."""


def part_order(sample: LabelledAssembly) -> np.ndarray:
    """The canonical numbering of the parts: sorted by type, then by rounded pose (row by row);
    ties (two parts of one type at one pose) keep their order."""
    keys = [
        (part.type.value, tuple(np.round(part.pose, POSE_DECIMALS).ravel() + 0.0))
        for part in sample.assembly.parts
    ]
    return np.array(sorted(range(len(keys)), key=keys.__getitem__), dtype=np.int64)


def renumber_masks(masks: np.ndarray, order: np.ndarray) -> np.ndarray:
    """Part bitmasks with part `order[k]` renamed to part k."""
    masks = np.asarray(masks, dtype=np.int64)
    out = np.zeros_like(masks)
    for new, old in enumerate(order):
        out |= ((masks >> int(old)) & 1) << new
    return out


def assembly_key(sample: LabelledAssembly, renumbered: bool = True) -> str:
    """A digest equal for two assemblies iff they have the same part types, poses and ground
    truth; with `renumbered`, also when their parts are numbered differently (the canonical
    form), else only in the same numbering (an exact copy)."""
    n = sample.size
    order = part_order(sample) if renumbered else np.arange(n, dtype=np.int64)
    parts = [sample.assembly.parts[i] for i in order]
    truth = sample.truth
    table = np.stack(
        [renumber_masks(m, order) for m in (truth.states, truth.placeable, truth.completable)],
        axis=1,
    )
    table = table[np.lexsort(table.T[::-1])]
    digest = hashlib.sha256()
    for part in parts:
        digest.update(part.type.value.encode())
        digest.update((np.round(part.pose, POSE_DECIMALS) + 0.0).astype(np.float64).tobytes())
    digest.update(table.astype(np.int64).tobytes())
    return digest.hexdigest()


def copy_groups(samples: list[LabelledAssembly], renumbered: bool = True) -> np.ndarray:
    """Per assembly the index of the first assembly it is a copy of (itself if none), by
    :func:`assembly_key`."""
    first: dict[str, int] = {}
    return np.array(
        [first.setdefault(assembly_key(s, renumbered), i) for i, s in enumerate(samples)],
        dtype=np.int64,
    )
