"""Self-training's per-round figures (grace/tasks/self_train.py): what each round added and what
its model scores on the test sizes, as self_train.json and self_train.md
(docs/size-generalisation.md, "Self-training"); and several runs' figures pooled over their
training seeds (`pooled_markdown`, written by task=gather)."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np

from grace.data.atomic import finite_or_null
from grace.errors import UserError
from grace.evaluation.report import mean_std
from grace.evaluation.results import hydra_overrides
from grace.evaluation.tables import cell, markdown_table

SELF_TRAIN_FILE = "self_train.json"
"""What task=self_train writes into its run folder and task=gather pools."""


class Labels(StrEnum):
    """Who labels the drawn assemblies (`task.labels`)."""

    verified = "verified"  # the verified search with the current model (self-training)
    brute_force = "brute_force"  # the simulator's ground truth (the upper bound)


REPLICATE_SETTINGS = ("seed",)
"""Settings in which runs pooled into one row may differ: they repeat, not vary, a run."""

LATER_SETTINGS = {
    "probe_own_sequence": False,
    "patience": None,
    "model": [],
    "threshold": {"_target_": "grace.planning.thresholds.AbsoluteThreshold"},
}
"""Settings added after runs were made, with the value those runs had (they planned under the
paper's λ); any other setting a run does not name had the null it defaults to
(`task.probe_checks`)."""


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
    # mean over this round's feasible masked labels of the share of unplaced parts' labels known
    known_share: float | None = None
    # this round's model: share of the next round's feasible drawn assemblies (the last round:
    # of one more draw) whose first choice the simulator accepts throughout (no ground truth)
    first_choice: float | None = None
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
    """The rounds as one table: added assemblies, verified share, the share of known labels
    (masked verified labels), wall time, the round's model's first choice verified on fresh
    draws (`RoundFigures.first_choice`), then strict P@1 and the no-sequence share per test
    size."""
    sizes = sorted({int(s) for r in rounds for s in r.test})
    head = ["round", "drawn", "verified share", "infeasible", "not found", "added", "known share"]
    head += ["wall s", "first choice (drawn)"]
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
        row += [str(r.not_found), str(r.added), _cell(r.known_share)]
        row += [f"{sum(r.seconds.values()):.0f}", _cell(r.first_choice)]
        row += [_cell(r.test.get(str(s), {}).get("p_at_1_strict")) for s in sizes]
        row += [_cell(r.test.get(str(s), {}).get("no_sequence_share")) for s in sizes]
        lines.append("| " + " | ".join(row) + " |")
    chosen = chosen_round([r.first_choice for r in rounds])
    if chosen is not None:
        lines += ["", f"Chosen round (its first choice on fresh draws right most often): {chosen}"]
    return "\n".join(lines) + "\n"


def model_overrides(overrides: Sequence[str]) -> list[str]:
    """The overrides of a run that change its model (`model…=`, e.g. `model/loss=listwise`):
    runs that differ in them are pooled apart."""
    return sorted(o for o in overrides if o.lstrip("+~").startswith(("model.", "model/", "model=")))


def read_self_train(path: Path) -> dict[str, Any]:
    """A run's self_train.json. A run written before its settings named the model overrides
    gets them from the command line Hydra kept beside it (.hydra/overrides.yaml), if any."""
    body = json.loads(path.read_text())
    kept = hydra_overrides(path.parent)
    if "model" not in body["settings"] and kept is not None:
        body["settings"]["model"] = model_overrides(kept)
    return body


def _label_source(settings: Mapping[str, Any]) -> str:
    model = "".join(f" · {o}" for o in settings.get("model", []))
    if Labels(settings["labels"]) is not Labels.verified:
        return f"{settings['labels']}{model}"
    source = "verified, masked" if settings.get("mask_unknown", False) else "verified, unmasked"
    probe = settings.get("probe_checks")
    if probe is None:
        return f"{source}{model}"
    own = " and on its own sequence" if settings.get("probe_own_sequence", False) else ""
    return f"{source}, probed ({probe} checks){own}{model}"


def chosen_round(judged: Sequence[float | None]) -> int | None:
    """The round whose model's first choice on fresh draws is right most often (`judged`, each
    round's `RoundFigures.first_choice`), the earlier one on a tie (it trained on fewer labels);
    None unless every round was judged. It reads no test ground truth: R chosen per run without
    one."""
    if not judged or None in judged:
        return None
    return int(np.argmax(judged))


def _row(source: str, label: str, done: Sequence[Mapping[str, Any]], sizes: list[int]) -> list:
    added = sorted({d["added"] for d in done})
    shown = str(added[0]) if len(added) == 1 else f"{added[0]}–{added[-1]}"
    judged = [d.get("first_choice") for d in done]  # runs from before it lack it
    first = cell(mean_std(judged)) if None not in judged else "–"
    row = [source, label, str(len(done)), shown, first]
    for key in ("p_at_1_strict", "no_sequence_share"):
        row += [cell(mean_std([d["test"][str(s)][key] for d in done])) for s in sizes]
    return row


def pooled_markdown(runs: Sequence[Mapping[str, Any]]) -> str:
    """Self-training runs (their self_train.json) pooled over training seeds: per label source
    and round, mean ± std over the runs of the round's model's first choice verified on fresh
    draws (when every run has it), of strict P@1 and of the no-sequence share per test size;
    when every run's rounds were judged, a row "chosen" pools each run's `chosen_round`.
    Runs pooled into one source must agree on every setting but the seed."""
    groups: dict[str, list[Mapping[str, Any]]] = {}
    for body in runs:
        groups.setdefault(_label_source(body["settings"]), []).append(body)
    sizes = sorted({int(s) for b in runs for r in b["rounds"] for s in r["test"]})
    head = ["labels", "round", "seeds", "added", "first choice (drawn)"]
    head += [f"strict P@1 A{s}" for s in sizes] + [f"no sequence A{s}" for s in sizes]
    rows = []
    for source, bodies in sorted(groups.items()):
        names = {k for b in bodies for k in b["settings"]} - set(REPLICATE_SETTINGS)
        fixed = [{k: b["settings"].get(k, LATER_SETTINGS.get(k)) for k in names} for b in bodies]
        if any(f != fixed[0] for f in fixed):
            raise UserError(
                f"{SELF_TRAIN_FILE}: runs of '{source}' labels differ in more than "
                f"{', '.join(REPLICATE_SETTINGS)}; fix: gather them from separate task.roots"
            )
        last = min(len(b["rounds"]) for b in bodies)
        for r in range(last):
            rows.append(_row(source, str(r), [b["rounds"][r] for b in bodies], sizes))
        chosen = [chosen_round([d.get("first_choice") for d in b["rounds"][:last]]) for b in bodies]
        if None not in chosen:
            picked = [b["rounds"][c] for b, c in zip(bodies, chosen, strict=True)]
            rows.append(_row(source, f"chosen ({', '.join(map(str, chosen))})", picked, sizes))
    return markdown_table(head, rows) + "\n"
