"""One labelled assembly ↔ one JSON record, the unit of the data-set shard files.

The record is lossless and compact: parts with name, type and pose; surface relations only where
they differ from what the poses give (raw imports); the ground-truth DAG; the simulator's info
without volatile keys (timings), so the same seed always gives the same bytes.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from grace.domain.assembly import Assembly, Part, PartType
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly

VOLATILE_INFO_KEYS = frozenset({"seconds"})
"""Info keys that vary between runs of the same seed; kept out of the data set bytes."""


def _plain(value: Any) -> Any:
    """JSON fallback for numpy scalars and arrays the simulator may put into `info`."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"info value {value!r} of type {type(value).__name__} is not JSON-serialisable")


def to_record(sample: LabelledAssembly) -> dict[str, Any]:
    """The JSON-able record of `sample` (see module docstring)."""
    assembly, truth = sample.assembly, sample.truth
    record: dict[str, Any] = {
        "name": assembly.name,
        "parts": [[p.name, p.type.value, p.pose.ravel().tolist()] for p in assembly.parts],
    }
    differ = np.argwhere(assembly.relations != assembly.geometric_relations())
    if len(differ):
        record["relations"] = [[int(i), int(j), float(assembly.relations[i, j])] for i, j in differ]
    record["truth"] = {
        "n_parts": truth.n_parts,
        "states": truth.states.tolist(),
        "placeable": truth.placeable.tolist(),
        "completable": truth.completable.tolist(),
        "checks": int(truth.checks),
        "naive_checks": int(truth.naive_checks),
    }
    record["info"] = {k: v for k, v in sample.info.items() if k not in VOLATILE_INFO_KEYS}
    return record


def from_record(record: dict[str, Any]) -> LabelledAssembly:
    """Inverse of :func:`to_record`."""
    parts = tuple(
        Part(name, PartType(kind), np.asarray(pose, dtype=float).reshape(4, 4))
        for name, kind, pose in record["parts"]
    )
    assembly = Assembly(parts, name=record["name"])
    if "relations" in record:
        relations = assembly.relations.copy()
        for i, j, value in record["relations"]:
            relations[i, j] = value
        assembly.relations = relations
    t = record["truth"]
    truth = GroundTruth(
        n_parts=t["n_parts"],
        states=np.asarray(t["states"], dtype=np.int64),
        placeable=np.asarray(t["placeable"], dtype=np.int64),
        completable=np.asarray(t["completable"], dtype=np.int64),
        checks=t["checks"],
        naive_checks=t["naive_checks"],
    )
    return LabelledAssembly(assembly, truth, dict(record["info"]))


def dumps(sample: LabelledAssembly) -> str:
    """One deterministic JSON line (sorted keys, no spaces, shortest-repr floats)."""
    return json.dumps(to_record(sample), sort_keys=True, separators=(",", ":"), default=_plain)


def loads(line: str) -> LabelledAssembly:
    return from_record(json.loads(line))
