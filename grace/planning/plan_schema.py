"""plan.json's keys and types, the source of docs/plan-schema.json (docs/planning.md, "plan.json").

The JSON shape of grace/planning/plans.py's records as grace/planning/plan_file.py writes them:
every plan has `orders`; the verified search's keys and the top-k listing's are each present
only in their planner's plan. Planning itself never imports pydantic (the task's start-up);
the schema is generated with it: `python -m grace.planning.plan_schema > docs/plan-schema.json`.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any, NotRequired

from typing_extensions import TypedDict  # pydantic needs it before Python 3.12

SCHEMA_FILE = Path(__file__).resolve().parents[2] / "docs" / "plan-schema.json"
_STRICT = {"extra": "forbid"}


class SimulatorJson(TypedDict):
    """The simulator's verdict on each step up to the first refused one (0-based
    `failing_step`, null when every step is feasible), and there the deciding rule, the
    placed parts that block it and why."""

    __pydantic_config__ = _STRICT  # type: ignore[misc]
    feasible: bool
    verdicts: list[bool]
    failing_step: int | None
    rule: str | None
    blocking_parts: list[int]
    reason: str | None


class OrderJson(TypedDict):
    """One order, best first: its parts (numbers and names), the network's probability and
    step scores, the simulator's verdicts, and whether the raw folder's ground truth holds it
    (null: none given)."""

    __pydantic_config__ = _STRICT  # type: ignore[misc]
    rank: int
    sequence: list[int]
    parts: list[str]
    probability: float
    step_scores: list[float]
    simulator: SimulatorJson
    ground_truth: bool | None


class RefusedJson(TypedDict):
    """A step the verified search saw refused: the parts placed, the part, the rule, the parts
    that block it, why."""

    __pydantic_config__ = _STRICT  # type: ignore[misc]
    placed: list[int]
    part: int
    rule: str | None
    blocking_parts: list[int]
    reason: str


class RefusalsJson(TypedDict):
    """The verified search's refused steps: counted, by rule, the first 20 listed."""

    __pydantic_config__ = _STRICT  # type: ignore[misc]
    count: int
    by_rule: dict[str, int]
    first: list[RefusedJson]


class ProofJson(TypedDict):
    """The part no order can place (docs/planning.md, "Infeasibility without a search")."""

    __pydantic_config__ = _STRICT  # type: ignore[misc]
    part: int
    name: str
    reason: str


class PlanJson(TypedDict):
    """plan.json of task=plan, either planner. `planner` holds its name ("verified" or "topk")
    and settings; `outcome` is "verified", "infeasible" or "not found within budget" for the
    verified search, "listed" for the top-k listing."""

    __pydantic_config__ = _STRICT  # type: ignore[misc]
    checkpoint: str
    assembly: str
    load_seconds: float
    seconds: float
    planner: dict[str, Any]
    name: str
    n_parts: int
    outcome: str
    orders: list[OrderJson]
    # the verified search
    checks: NotRequired[int]
    first_checks: NotRequired[int | None]
    expanded: NotRequired[int]
    first_seconds: NotRequired[float | None]
    record_seconds: NotRequired[float | None]
    refused: NotRequired[RefusalsJson]
    proof: NotRequired[ProofJson]
    # the top-k listing
    feasibility: NotRequired[float | None]
    ground_truth_orders: NotRequired[int | None]
    stopped_by_budget: NotRequired[bool]


def plan_schema() -> dict[str, Any]:
    """The JSON schema of plan.json (draft 2020-12), generated from PlanJson."""
    from pydantic import TypeAdapter  # only to generate or validate the schema

    schema = TypeAdapter(PlanJson).json_schema(mode="serialization")
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}


def validate_plan_json(data: Any) -> None:
    """Raise pydantic's ValidationError unless `data` has plan.json's keys and types."""
    from pydantic import TypeAdapter

    TypeAdapter(PlanJson).validate_python(data, strict=True)


def schema_text() -> str:
    """docs/plan-schema.json's text."""
    return json.dumps(plan_schema(), indent=2, ensure_ascii=False) + "\n"


if __name__ == "__main__":
    # python -m grace.planning.plan_schema > docs/plan-schema.json
    sys.stdout.write(schema_text())
