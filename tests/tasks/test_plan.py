"""task=plan: a kept model plans a hand-made assembly; the simulator checks every listed order."""

from __future__ import annotations

import itertools
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from hydra.utils import instantiate

from grace.cli.fit import keep_config
from grace.data.raw_format import read_assembly
from grace.errors import UserError
from grace.planning.plan_schema import validate_plan_json
from grace.tasks.plan import run
from grace.visualisation.recording import summarise, text_entries

# Hand-made: a 300 mm bar, a 200 mm stem and an angle bracket joining them. Placed first, the
# bracket has nothing to hold it (fixation); placed last, between both profiles, the gripper's
# fingers hit them (fingers). So the bracket goes second.
PIECES = """begin Pieces
bar item_profile_300 0;-1;0;0&1;0;0;0&0;0;1;0&0;0;0;1
stem item_profile_200 1;0;0;0.25&0;1;0;120&0;0;1;0&0;0;0;1
br item_angle_bracket 1;0;0;20.25&0;1;0;20&0;0;1;0&0;0;0;1
end Pieces
"""
KNOWN_ORDERS = {(0, 2, 1), (1, 2, 0)}  # bar, bracket, stem / stem, bracket, bar
RAILS = """begin Pieces
bar item_profile_300 0;-1;0;0&1;0;0;0&0;0;1;0&0;0;0;1
left item_profile_200 1;0;0;-24&0;1;0;120&0;0;1;0&0;0;0;1
right item_profile_200 1;0;0;24&0;1;0;120&0;0;1;0&0;0;0;1
end Pieces
"""


def fit(cfg_factory, root):
    """A small GRACE fitted to the hand-made assembly's states (a plain Adam loop: Lightning's
    per-epoch work would cost more than the fit), kept as a run would keep it."""
    (root / "asm").mkdir()
    (root / "asm" / "assembly.spec").write_text(PIECES)
    cfg = cfg_factory("task=train", "model.net.hidden=32", "model.net.pair_readout=16", "threads=1")
    assembly, truth = read_assembly(root / "asm")
    assert truth is None  # a lone assembly.spec: no ground truth given
    sample = instantiate(cfg.simulator).label(assembly)
    assert set(sample.truth.orders()) == KNOWN_ORDERS  # the world's answer this test relies on
    torch.manual_seed(0)
    module = instantiate(cfg.model)
    data = instantiate(cfg.datamodule)(
        train=[sample], val=[], enc=module.enc, collate=module.impl.collate
    )
    batches = list(data.train_dataloader())
    optimiser = torch.optim.Adam(module.parameters(), lr=0.01)
    for _ in range(150):
        for batch in batches:
            loss = module.loss(batch, module(batch))
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
    (root / "train" / "checkpoints").mkdir(parents=True)
    torch.save({"state_dict": module.state_dict()}, root / "train" / "checkpoints" / "best.ckpt")
    keep_config(cfg, root / "train")
    return sample.truth


def plan(cfg_factory, ckpt, assembly, *overrides):
    cfg = cfg_factory("task=plan", f"ckpt={ckpt}", f"assembly={assembly}", *overrides)
    run(cfg)
    text = (Path(cfg.paths.output_dir) / "plan.json").read_text()
    result = json.loads(text, parse_constant=_not_json)
    validate_plan_json(result)  # docs/plan-schema.json's keys and types
    return result, cfg


def _not_json(constant: str):
    raise ValueError(f"plan.json holds {constant}: strict JSON parsers reject it")


def test_plan_with_a_model_fitted_to_a_hand_made_assembly(cfg_factory, tmp_path):
    truth = fit(cfg_factory, tmp_path)
    placeable = dict(zip(truth.states.tolist(), truth.placeable.tolist(), strict=True))
    train, asm = tmp_path / "train", tmp_path / "asm"
    assert (train / "config.yaml").is_file() and (train / "checkpoints" / "best.ckpt").is_file()

    # Algorithm 1 at λ = 0.5 retrieves exactly the known orders; the simulator passes them.
    result, _ = plan(
        cfg_factory, train, asm, "planner=topk", "planner.k=6", "planner.threshold=0.5"
    )
    assert {tuple(s["sequence"]) for s in result["orders"]} == KNOWN_ORDERS
    assert all(s["simulator"]["feasible"] for s in result["orders"])
    assert result["feasibility"] >= 0.5 and result["outcome"] == "listed"
    assert result["planner"]["name"] == "topk" and result["planner"]["k"] == 6

    # All 3! orders best first: the known ones first, every other one refused by the simulator
    # at its first step outside them, with the deciding rule.
    result, cfg = plan(
        cfg_factory, train / "checkpoints" / "best.ckpt", asm, "planner=topk", "planner.k=6",
        "task.recording=true",
    )  # fmt: skip
    ranked = [tuple(s["sequence"]) for s in result["orders"]]
    assert sorted(ranked) == sorted(itertools.permutations(range(3)))
    assert set(ranked[:2]) == KNOWN_ORDERS
    for entry in result["orders"]:
        order, sim = tuple(entry["sequence"]), entry["simulator"]
        assert sim["feasible"] == (order in KNOWN_ORDERS)
        if not sim["feasible"]:
            # the first step the ground truth's reachable-state DAG does not allow
            state, step = 0, 0
            while placeable[state] >> order[step] & 1:
                state, step = state | 1 << order[step], step + 1
            assert sim["failing_step"] == step and sim["rule"] and sim["reason"]
    rrd = Path(cfg.paths.output_dir) / "plan.rrd"
    summary = summarise(rrd)
    assert {"/plan/asm/sequences", "/plan/asm/cell/parts", "/plan/asm/scores"} <= set(
        summary.entities
    )
    assert summary.steps == (0, 2)
    refused = [t for _, _, t in text_entries(rrd, "/failures")]
    assert len(refused) == 4 and all("is refused by the simulator" in t for t in refused)
    assert any("fingers: finger hits part" in t for t in refused)
    assert any("fixation" in t for t in refused)

    # The default planner, the verified search: only orders every step of which the simulator
    # accepts, the most probable first, and the search itself in plan.rrd.
    result, cfg = plan(cfg_factory, train, asm, "planner.k=2", "task.recording=true")
    assert result["outcome"] == "verified" and result["checks"] >= 3
    assert {tuple(o["sequence"]) for o in result["orders"]} == KNOWN_ORDERS
    assert all(all(o["simulator"]["verdicts"]) and len(o["simulator"]["verdicts"]) == 3
               for o in result["orders"])  # fmt: skip
    probabilities = [o["probability"] for o in result["orders"]]
    assert probabilities == sorted(probabilities, reverse=True)
    rrd = Path(cfg.paths.output_dir) / "plan.rrd"
    summary = summarise(rrd)
    assert {"/plan/asm/search/log", "/plan/asm/search/tree", "/plan/asm/cell/parts"} <= set(
        summary.entities
    )
    assert any("placed" in t for _, _, t in text_entries(rrd, "/search/log"))
    # Two stems 8 mm apart: whichever comes second cannot be gripped. Infeasible, and said so.
    rails = tmp_path / "rails"
    rails.mkdir()
    (rails / "assembly.spec").write_text(RAILS)
    result, cfg = plan(cfg_factory, train, rails)
    assert result["outcome"] == "infeasible" and result["orders"] == []
    # Proved before any step check: each stem's options need the other one out of the way.
    assert result["checks"] == 0 and result["refused"]["count"] == 0
    assert result["proof"]["name"] in {"left", "right"} and result["proof"]["reason"]
    result, _ = plan(cfg_factory, train, rails, "planner.precedence=false")
    assert result["outcome"] == "infeasible" and "proof" not in result
    assert result["refused"]["count"] >= 1 and result["refused"]["first"][0]["reason"]

    # Bad inputs: one UserError line each.
    with pytest.raises(UserError, match="no checkpoint there"):
        plan(cfg_factory, tmp_path / "nothing", asm)
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "assembly.spec").write_text("begin Pieces\nx item_profile_400 1\nend Pieces\n")
    with pytest.raises(UserError, match="unknown part type"):
        plan(cfg_factory, train, bad)
    (bad / "assembly.spec").write_text(
        "begin Pieces\nx item_profile_200 1;0;0;1.7e308&0;1;0;0&0;0;1;0&0;0;0;1\n"
        "y item_profile_200 1;0;0;-1.7e308&0;1;0;0&0;0;1;0&0;0;0;1\nend Pieces\n"
    )
    with pytest.raises(UserError, match=r"assembly\.spec:2: .*outside the cell's workspace"):
        plan(cfg_factory, train, bad)
    other = tmp_path / "other"  # the checkpoint beside the config of a different network
    shutil.copytree(train / "checkpoints", other / "checkpoints")
    text = (train / "config.yaml").read_text().replace("hidden: 32", "hidden: 40")
    (other / "config.yaml").write_text(text)
    with pytest.raises(UserError, match="was made for another config"):
        plan(cfg_factory, other, asm)
    (other / "checkpoints" / "best.ckpt").write_text("not a checkpoint")
    with pytest.raises(UserError, match="not a readable Lightning checkpoint"):
        plan(cfg_factory, other, asm)


def test_the_command_prints_one_line_and_exits_non_zero(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "grace", "task=plan", f"ckpt={tmp_path}", f"assembly={tmp_path}",
         f"hydra.run.dir={tmp_path / 'run'}"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode != 0
    errors = [line for line in result.stderr.splitlines() if line.startswith("grace: error:")]
    assert len(errors) == 1 and "ckpt=" in errors[0] and "Traceback" not in result.stderr


@pytest.mark.slow  # a second fit and a whole process start-up (seconds of imports)
def test_plan_from_the_command_line_imports_only_what_planning_needs(cfg_factory, tmp_path):
    """The same answer as in this process, without the libraries planning does not need, each
    seconds to import (Lightning, PyG, torch.compile's stack, rerun, matplotlib), and without
    plan.rrd unless asked for."""
    fit(cfg_factory, tmp_path)
    train, asm = tmp_path / "train", tmp_path / "asm"
    result, _ = plan(cfg_factory, train, asm, "planner.k=2")
    out = tmp_path / "cli"
    done = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "grace", "task=plan", f"ckpt={train}",
         f"assembly={asm}", "planner.k=2", f"paths.output_dir={out}",
         f"paths.data_dir={tmp_path / 'data'}"],
        cwd=tmp_path, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    imported = {
        line.split("|")[-1].strip() for line in done.stderr.splitlines() if "import time:" in line
    }
    heavy = {"lightning", "torch_geometric", "torchmetrics", "rerun", "matplotlib", "sklearn"}
    assert not {m for m in imported if m.split(".")[0] in heavy}
    assert "torch._dynamo" not in imported and "torch" in imported
    cli = json.loads((out / "plan.json").read_text())
    assert [o["sequence"] for o in cli["orders"]] == [o["sequence"] for o in result["orders"]]
    assert not (out / "plan.rrd").exists() and "plan.rrd" not in done.stdout
