"""results.json as typed records: what an experiment run writes, and every reader reads.

`ExperimentResults` is the whole file; a size's entry is a `SizeSummary`. Sizes are string keys
(JSON's), ascending. A metric that no fold defined for a size is absent from the file, never zero
(a field that is None here is left out when written). std is the population standard deviation
over folds (ddof = 0), or over the runs' means in a pooled entry (task=gather, task=report),
which also carries the number of `runs`. Definitions of the metrics: docs/metrics.md; the JSON
schema, generated from these classes by `python -m grace.evaluation.results`:
docs/results-schema.json.

pydantic reads and writes the records (and checks a file's types when it is read): it builds
the JSON schema from the same classes, so the schema cannot drift from the code.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import yaml
from pydantic import (
    AliasChoices,
    BeforeValidator,
    ConfigDict,
    Field,
    PlainSerializer,
    TypeAdapter,
    ValidationError,
)

from grace.data.atomic import strict_json
from grace.errors import UserError

OMITTED_IF_NONE = Field(default=None, exclude_if=lambda value: value is None)
"""A field that is absent from the file when undefined."""

Number = Annotated[
    float,
    BeforeValidator(lambda value: math.nan if value is None else value),
    PlainSerializer(
        lambda value: value if math.isfinite(value) else None, return_type=float | None
    ),
]
"""A float that may be undefined (NaN: e.g. a step AUC without a positive label): null in the
file, which strict JSON parsers read (they reject NaN), NaN again when read."""

CONFIG = ConfigDict(use_attribute_docstrings=True)
"""Field docstrings become the schema's descriptions."""

RESULTS_FILE = "results.json"
SCHEMA_FILE = Path(__file__).resolve().parents[2] / "docs" / "results-schema.json"


def hydra_overrides(run_dir: Path) -> list[str] | None:
    """The command-line overrides Hydra kept in a run folder (.hydra/overrides.yaml), None
    where it kept none."""
    kept = run_dir / ".hydra" / "overrides.yaml"
    return [str(o) for o in yaml.safe_load(kept.read_text()) or []] if kept.is_file() else None


@dataclass
class Stat:
    """A metric over folds (or over runs when pooled)."""

    __pydantic_config__ = CONFIG
    mean: float
    """Mean over the folds that define the metric."""
    std: float
    """Population standard deviation (ddof = 0)."""
    runs: Annotated[int | None, OMITTED_IF_NONE] = None
    """Runs pooled into this entry (gathered results only)."""


@dataclass
class CountedStat(Stat):
    """A P@k over folds with the assemblies it counted."""

    __pydantic_config__ = CONFIG
    assemblies: int = 0
    """Test assemblies counted (at least k ground-truth orders), summed over folds."""
    empty: int = 0
    """Of those, how many retrieved no complete sequence at λ."""


@dataclass
class Confusion:
    """Feasibility confusion at λ: positive = feasible, predicted feasible = a sequence found."""

    __pydantic_config__ = CONFIG
    tp: int
    fp: int
    tn: int
    fn: int


@dataclass
class SchemeSummary:
    """One feasibility scheme (grace/evaluation/feasibility_schemes.py)."""

    __pydantic_config__ = CONFIG
    roc_auc: Stat
    """ROC AUC of the scheme's feasibility score, positive = feasible."""
    tpr_at_fpr: Annotated[Stat | None, OMITTED_IF_NONE] = None
    """True-positive rate at a false-positive rate ≤ 0.05."""


@dataclass
class FeasibilitySummary:
    """Feasibility of one test size."""

    __pydantic_config__ = CONFIG
    confusion: Confusion
    """Counts summed over folds."""
    schemes: Annotated[dict[str, SchemeSummary] | None, OMITTED_IF_NONE] = None
    """Per scheme (defined ones only)."""


@dataclass(kw_only=True)
class SizeSummary:
    """One policy on the test assemblies of one size, over all folds."""

    __pydantic_config__ = CONFIG
    folds: int
    """Folds that tested this size."""
    assemblies: int
    """Test assemblies, summed over folds."""
    forward_passes: int
    """States scored (≤ 2^N − 1 per assembly), summed over folds."""
    step_auc: Annotated[Stat | None, OMITTED_IF_NONE] = None
    """The paper's step-by-step AUC (on-path states)."""
    placeable_auc_offpath: Annotated[
        Stat | None,
        Field(
            default=None,
            exclude_if=lambda value: value is None,
            validation_alias=AliasChoices("placeable_auc_offpath", "step_auc_offpath"),
        ),
    ] = None
    """Physics recall off the ground-truth orders: PR AUC of the part scores against the
    simulator's placeable mask in the states from which no order completes (read from
    `step_auc_offpath` in older runs)."""
    offpath_states: Annotated[int | None, OMITTED_IF_NONE] = None
    """Off-path states scored, summed over folds (absent in runs older than the metric)."""
    dead_end_pass_rate: Annotated[Stat | None, OMITTED_IF_NONE] = None
    """Share of the feasible steps into dead ends, from the states on the ground-truth orders,
    that score ≥ λ (lower is better)."""
    dead_end_steps: Annotated[int | None, OMITTED_IF_NONE] = None
    """Feasible steps into dead ends from the states on the ground-truth orders, summed over
    folds."""
    dead_end_leakage: Annotated[Stat | None, OMITTED_IF_NONE] = None
    """Share of the off-path states in which some unplaced part scores ≥ λ (lower is better)."""
    seq_auc: Annotated[Stat | None, OMITTED_IF_NONE] = None
    """Complete-sequence AUC, the paper's rule (an empty retrieval has precision 1)."""
    seq_auc_strict: Annotated[Stat | None, OMITTED_IF_NONE] = None
    """Strict complete-sequence AUC (an empty retrieval has precision 0)."""
    p_at_k: Annotated[dict[str, CountedStat] | None, OMITTED_IF_NONE] = None
    """P@k per k, the paper's rule (an empty retrieval scores 1)."""
    p_at_k_strict: Annotated[dict[str, CountedStat] | None, OMITTED_IF_NONE] = None
    """Strict P@k per k (an empty retrieval scores 0)."""
    no_sequence: int
    """Feasible test assemblies with no complete sequence at λ."""
    feasibility: FeasibilitySummary
    """Feasibility confusion and schemes."""


@dataclass
class PolicyResults:
    """A baseline's figures on the same test assemblies."""

    __pydantic_config__ = CONFIG
    per_size: dict[str, SizeSummary]


@dataclass
class StageSeconds:
    """Wall-clock seconds per stage."""

    __pydantic_config__ = CONFIG
    load: float
    """Loading (or generating) the data set."""
    train: list[float]
    """Training, per fold."""
    evaluate: list[float]
    """Evaluation, per fold."""


@dataclass
class SizeHealth:
    """GRACE's on-path test step AUC of one size against the best floor's."""

    __pydantic_config__ = CONFIG
    step_auc: Number
    floor: Number


@dataclass
class TrainingCurve:
    """What a fold's training log shows (grace/evaluation/collapse.py)."""

    __pydantic_config__ = CONFIG
    epochs: int
    train_loss_first: Number
    train_loss_min: Number
    val_step_auc_best: float | None
    val_floor: Number
    """The constant scorer's step AUC on the validation states."""


@dataclass
class FoldHealth:
    """Did a fold's model learn anything (docs/metrics.md, collapse)."""

    __pydantic_config__ = CONFIG
    fold: int
    model: Annotated[str | None, OMITTED_IF_NONE] = None
    """Which of the fold's models (task=feasibility trains two)."""
    sizes: dict[str, SizeHealth] = field(default_factory=dict)
    training: TrainingCurve | str = "no training log found"
    """The training curve, or why there is none."""
    collapsed: bool = False
    reasons: list[str] = field(default_factory=list)


@dataclass
class RunInfo:
    """What made the run; absent in the oldest run folders."""

    __pydantic_config__ = CONFIG
    model: str | None = None
    """The model option (model.name)."""
    seed: int | None = None
    """The training seed."""
    data_seed: int | None = None
    """The data set's seed (null for raw data; absent in older runs)."""
    overrides: list[str] = field(default_factory=list)
    """The command-line overrides of the run."""


@dataclass
class ExperimentResults:
    """results.json of an experiment run (task=experiment)."""

    __pydantic_config__ = CONFIG
    protocol: str
    """intra, many_to_one or one_to_many (docs/protocols.md)."""
    train_sizes: list[int]
    test_sizes: list[int]
    folds: int
    per_size: dict[str, SizeSummary]
    """GRACE, per test size."""
    baselines: dict[str, PolicyResults]
    """The baselines and floors of task.baselines, on the same test assemblies."""
    seconds: float
    """Wall clock of the whole run."""
    seconds_by_stage: StageSeconds
    collapsed_folds: list[int] = field(default_factory=list)
    fold_health: list[FoldHealth] = field(default_factory=list)
    run: Annotated[RunInfo | None, OMITTED_IF_NONE] = None

    def policies(self) -> dict[str, dict[str, SizeSummary]]:
        """GRACE then every baseline: name → per-size summaries."""
        return {"GRACE": self.per_size} | {n: b.per_size for n, b in self.baselines.items()}


RESULTS = TypeAdapter(ExperimentResults)


def plain(value: Any, adapter: TypeAdapter | None = None) -> Any:
    """A record as JSON-ready data (dicts, lists, numbers), its undefined fields left out."""
    if value is None:
        return None
    return (adapter or TypeAdapter(type(value))).dump_python(value)


def to_json(value: Any, adapter: TypeAdapter | None = None) -> str:
    """`value` (records, or plain data holding records) as indented strict JSON: a non-finite
    number is null (grace.data.atomic.strict_json)."""
    return strict_json(plain(value, adapter)) + "\n"


def read_results(path: str | Path) -> ExperimentResults:
    """The results.json at `path`; a malformed one is a UserError naming the file and field."""
    path = Path(path)
    try:
        return RESULTS.validate_python(json.loads(path.read_text()))
    except (OSError, json.JSONDecodeError) as error:
        raise UserError(f"{path}: not a readable results file ({error})") from None
    except ValidationError as error:
        first = error.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise UserError(
            f"{path}: field '{where}': {first['msg']}; fix: pass the results.json of an "
            "experiment run (task=experiment)"
        ) from None


def results_schema() -> dict[str, Any]:
    """The JSON schema of results.json (draft 2020-12), generated from ExperimentResults."""
    schema = RESULTS.json_schema(mode="serialization")
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}


def schema_text() -> str:
    """docs/results-schema.json's text."""
    return json.dumps(results_schema(), indent=2, ensure_ascii=False) + "\n"


if __name__ == "__main__":
    # python -m grace.evaluation.results > docs/results-schema.json
    sys.stdout.write(schema_text())
