"""Self-training's per-round figures (grace/tasks/self_train.py): what each round added and what
its model scores on the test sizes, as self_train.json and self_train.md
(docs/size-generalisation.md, "Self-training")."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from grace.data.atomic import finite_or_null


@dataclass
class RoundFigures:
    """One round: `round` 0 trains on the original training set only (R = 0); round r ≥ 1 first
    labels `drawn` new assemblies with the previous round's model, `labelled` of them got a
    label (`verified` an order, `infeasible` a proof), `added` is the self-labelled total the
    round trains on. Seconds per stage; `test` per size: the strict P@1, the no-sequence share
    of the feasible test assemblies, step AUC and strict sequence AUC (docs/metrics.md)."""

    round: int
    drawn: int = 0
    labelled: int = 0
    verified: int = 0
    infeasible: int = 0
    not_found: int = 0
    orders: int = 0
    added: int = 0
    seconds: dict[str, float] = field(default_factory=dict)
    test: dict[str, dict[str, float | int | None]] = field(default_factory=dict)

    @property
    def verified_share(self) -> float | None:
        return self.verified / self.drawn if self.drawn else None

    def to_json(self) -> dict[str, Any]:
        return finite_or_null({**asdict(self), "verified_share": self.verified_share})


def size_figures(metrics: Mapping[int, Mapping[str, Any]]) -> dict:
    """Per test size (str keys, as JSON has them): the headline figures of `metrics`
    (grace/evaluation/evaluate.py, `evaluate_by_size`, with k = 1)."""
    out = {}
    for size, entry in sorted(metrics.items()):
        p_at_1 = entry["p_at_k_strict"]["1"]
        n = int(p_at_1["assemblies"])  # the feasible ones: at least one order
        out[str(size)] = {
            "assemblies": int(entry["assemblies"]),
            "feasible": n,
            "p_at_1_strict": float(p_at_1["value"]),
            "no_sequence_share": int(entry["no_sequence"]) / n if n else float("nan"),
            "step_auc": float(entry["step_auc"]),
            "seq_auc_strict": float(entry["seq_auc_strict"]),
        }
    return out


def _cell(value: float | None) -> str:
    return "–" if value is None or not np.isfinite(value) else f"{value:.2f}"


def self_train_markdown(settings: Mapping[str, Any], rounds: Sequence[RoundFigures]) -> str:
    """The rounds as one table: added assemblies, verified share, wall time, then strict P@1
    and the no-sequence share per test size."""
    sizes = sorted({int(s) for r in rounds for s in r.test})
    head = ["round", "drawn", "verified share", "infeasible", "not found", "added", "wall s"]
    head += [f"strict P@1 A{s}" for s in sizes] + [f"no sequence A{s}" for s in sizes]
    lines = [
        f"# Self-training ({settings.get('labels')} labels)",
        "",
        ", ".join(f"{k}: {v}" for k, v in settings.items()),
        "",
        "| " + " | ".join(head) + " |",
        "| " + " | ".join("---" for _ in head) + " |",
    ]
    for r in rounds:
        row = [str(r.round), str(r.drawn), _cell(r.verified_share), str(r.infeasible)]
        row += [str(r.not_found), str(r.added), f"{sum(r.seconds.values()):.0f}"]
        row += [_cell(r.test.get(str(s), {}).get("p_at_1_strict")) for s in sizes]
        row += [_cell(r.test.get(str(s), {}).get("no_sequence_share")) for s in sizes]
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"
