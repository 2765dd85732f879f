"""The checked plan: both planners answer one product, plan.json has one shape (the committed
docs/plan-schema.json is the generated one, a written plan validates against it and reads back
to the same plan), and the plan.json files of earlier versions still read."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.utils import instantiate

from grace import CONF_DIR
from grace.cli.schemas import register_schemas
from grace.errors import UserError
from grace.evaluation.baselines import random_scorer
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.plan_file import plan_json, read_plan, write_plan
from grace.planning.plan_schema import SCHEMA_FILE, schema_text, validate_plan_json
from grace.planning.plans import LISTED, in_truth
from grace.planning.search import VerifiedSearch
from grace.planning.topk import TopKListing

OLD = Path(__file__).parent / "old_plans"
"""plan.json of the A12-000000 frame planned by the default model before the shapes were
unified (orders trimmed to two): the verified search's and the top-k listing's."""


def as_json(data):
    """`data` as plan.json reads back (tuples as lists)."""
    return json.loads(json.dumps(data))


@pytest.fixture(scope="module")
def labelled():
    register_schemas(light=True)
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(config_name="config")
    GlobalHydra.instance().clear()
    sim = instantiate(cfg.simulator)
    return sim, sim.label(sim.generate(5, np.random.default_rng(3)))


def test_the_committed_schema_is_the_generated_one():
    assert SCHEMA_FILE.read_text() == schema_text(), (
        "regenerate it: python -m grace.planning.plan_schema > docs/plan-schema.json"
    )


@pytest.mark.slow  # a real simulator and a labelled frame (seconds); test_plan.py covers the task
@pytest.mark.parametrize("planner", [VerifiedSearch(k=2), TopKListing(k=4)])
def test_both_planners_answer_a_plan_that_round_trips_through_plan_json(
    planner, labelled, tmp_path
):
    sim, sample = labelled
    assembly, truth = sample.assembly, sample.truth
    steps = SimulatorSteps(sim, assembly)
    plan = planner.checked_plan(random_scorer(0), assembly, steps, truth)
    plan = replace(plan, sources={"checkpoint": "c", "assembly": "a", "load_seconds": 0.1})
    assert plan.orders and [o.rank for o in plan.orders] == list(range(1, len(plan.orders) + 1))
    for order in plan.orders:
        sim_check = steps.checker.check(order.sequence)
        assert order.simulator.verdicts == tuple(v.feasible for v in sim_check.verdicts)
        assert order.simulator.failing_step == sim_check.failing_step
        assert order.ground_truth == in_truth(truth, order.sequence)
        assert (order.simulator.reason is None) == order.simulator.feasible
    verified = isinstance(planner, VerifiedSearch)
    assert (plan.search is not None, plan.listing is not None) == (verified, not verified)
    assert plan.outcome == ("verified" if verified else LISTED)
    path = tmp_path / "plan.json"
    write_plan(path, plan)
    written = json.loads(path.read_text())
    validate_plan_json(written)
    assert as_json(plan_json(read_plan(path))) == written
    if verified:  # the drawn events stay out of plan.json
        assert plan.search.events and "events" not in json.dumps(written)


def test_earlier_plan_json_files_read_into_the_one_shape():
    verified = read_plan(OLD / "verified.json")
    assert verified.planner["name"] == "verified" and verified.outcome == "verified"
    assert verified.search.checks == 24 and verified.search.refused.count == 6
    assert all(o.simulator.failing_step is None for o in verified.orders)
    topk = read_plan(OLD / "topk.json")
    assert topk.planner == {"name": "topk", "k": 10, "threshold": 0.0}
    assert topk.outcome == LISTED and topk.listing.ground_truth_orders == 672
    failing = topk.orders[1].simulator
    assert (failing.failing_step, failing.rule, failing.blocking_parts) == (4, "fingers", (2, 7, 8))
    old = json.loads((OLD / "topk.json").read_text())
    new = as_json(plan_json(topk))
    assert [o["simulator"] for o in new["orders"]] == [s["simulator"] for s in old["sequences"]]
    for plan in (verified, topk):
        validate_plan_json(as_json(plan_json(plan)))


def test_an_unreadable_plan_json_is_one_line(tmp_path):
    bad = tmp_path / "plan.json"
    bad.write_text('{"name": "x"}')
    with pytest.raises(UserError, match=r"plan\.json: field 'planner' missing; fix: "):
        read_plan(bad)
    bad.write_text("{")
    with pytest.raises(UserError, match=r"not a readable plan\.json"):
        read_plan(bad)
