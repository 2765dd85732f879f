"""plan.json: one shape for both planners, written atomically and read back (docs/planning.md,
"plan.json"; its schema is docs/plan-schema.json, grace/planning/plan_schema.py).

Every plan lists `orders`, each with its simulator verdicts; the verified search's facts
(checks, refused steps, proof) and the top-k listing's (feasibility, ground-truth orders) sit
beside them. `read_plan` also reads the plan.json of earlier versions: the verified search's
(the same, without the failing step's fields, no planner name) and the top-k listing's
(`sequences` for `orders`, `k` and `threshold` beside them).
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

from grace.data.atomic import write_json_atomic
from grace.errors import UserError
from grace.planning.plans import (
    LISTED,
    ListingFacts,
    Plan,
    PlannedOrder,
    Proof,
    Refusals,
    RefusedStep,
    SearchFacts,
    StepVerdicts,
)

SEARCH_KEYS = ("checks", "first_checks", "expanded", "first_seconds", "record_seconds")
LISTING_KEYS = ("feasibility", "ground_truth_orders", "stopped_by_budget")


def plan_json(plan: Plan) -> dict[str, Any]:
    """The plan as plan.json holds it (module docstring)."""
    out: dict[str, Any] = {
        **plan.sources,
        "seconds": plan.seconds,
        "planner": plan.planner,
        "name": plan.name,
        "n_parts": plan.n_parts,
        "outcome": plan.outcome,
    }
    if plan.search is not None:
        out.update({key: getattr(plan.search, key) for key in SEARCH_KEYS})
    if plan.listing is not None:
        out.update(asdict(plan.listing))
    out["orders"] = [asdict(order) for order in plan.orders]
    if plan.search is not None:
        out["refused"] = asdict(plan.search.refused)
        if plan.search.proof is not None:
            out["proof"] = asdict(plan.search.proof)
    return out


def write_plan(path: str | Path, plan: Plan) -> None:
    """Write plan.json atomically (strict JSON: grace/data/atomic.py)."""
    write_json_atomic(path, plan_json(plan))


def _order(entry: dict[str, Any]) -> PlannedOrder:
    sim = dict(entry["simulator"])
    verdicts = tuple(sim["verdicts"])
    if "failing_step" not in sim:  # the verified search's earlier plan.json
        sim["failing_step"] = next((i for i, v in enumerate(verdicts) if not v), None)
    return PlannedOrder(
        rank=entry["rank"],
        sequence=tuple(entry["sequence"]),
        parts=tuple(entry["parts"]),
        probability=entry["probability"],
        step_scores=tuple(entry["step_scores"]),
        simulator=StepVerdicts(
            feasible=sim["feasible"],
            verdicts=verdicts,
            failing_step=sim["failing_step"],
            rule=sim.get("rule"),
            blocking_parts=tuple(sim.get("blocking_parts", ())),
            reason=sim.get("reason"),
        ),
        ground_truth=entry["ground_truth"],
    )


def _search(data: dict[str, Any]) -> SearchFacts:
    refused = data["refused"]
    first = tuple(
        RefusedStep(
            tuple(r["placed"]), r["part"], r["rule"], tuple(r["blocking_parts"]), r["reason"]
        )
        for r in refused["first"]
    )
    proof = Proof(**data["proof"]) if data.get("proof") else None
    return SearchFacts(
        **{key: data.get(key) for key in SEARCH_KEYS},
        refused=Refusals(refused["count"], dict(refused["by_rule"]), first),
        proof=proof,
    )


def plan_from_json(data: dict[str, Any]) -> Plan:
    """The plan of a plan.json's content, of this version or an earlier one (module docstring)."""
    data = dict(data)
    if "sequences" in data:  # the top-k listing's earlier plan.json
        data["orders"] = data.pop("sequences")
        data["planner"] = {"name": "topk", "k": data.pop("k"), "threshold": data.pop("threshold")}
        data["outcome"] = LISTED
    planner = dict(data["planner"])
    planner.setdefault("name", "verified")  # only the verified search wrote a planner before
    verified = planner["name"] == "verified"
    known = {"seconds", "planner", "name", "n_parts", "outcome", "orders", "refused", "proof"}
    known |= set(SEARCH_KEYS) | set(LISTING_KEYS)
    return Plan(
        name=data["name"],
        n_parts=data["n_parts"],
        planner=planner,
        outcome=data["outcome"],
        orders=tuple(_order(o) for o in data["orders"]),
        seconds=data["seconds"],
        search=_search(data) if verified else None,
        listing=None if verified else ListingFacts(**{k: data[k] for k in LISTING_KEYS}),
        sources={k: v for k, v in data.items() if k not in known},
    )


def read_plan(path: str | Path) -> Plan:
    """The plan of a plan.json (this version's or an earlier one's)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise UserError(f"{path}: not a readable plan.json ({error})") from None
    try:
        return plan_from_json(data)
    except KeyError as error:
        raise UserError(
            f"{path}: field {error} missing; fix: pass the plan.json of a task=plan run"
        ) from None
    except (TypeError, AttributeError) as error:
        raise UserError(
            f"{path}: not a plan ({error}); fix: pass the plan.json of a task=plan run"
        ) from None
