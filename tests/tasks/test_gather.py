import json

import pytest
from omegaconf import OmegaConf

from grace.errors import UserError
from grace.tasks.gather import run


def _gather(runs, out):
    run(OmegaConf.create({"task": {"roots": [str(runs)]}, "paths": {"output_dir": str(out)}}))
    return json.loads((out / "gather.json").read_text()), (out / "gather.md").read_text()


def test_gather_builds_table2_and_table3(tmp_path, results_run, size_entry):
    runs = tmp_path / "multirun"
    random = {"random": size_entry(0.5)}
    results_run(
        runs / "intra" / "0", "intra", [3, 4, 5], [3, 4, 5], size_entry(0.97), (), 0, random
    )
    for i, size in enumerate((3, 4)):
        results_run(
            runs / "m2o" / str(i),
            "many_to_one",
            [s for s in (3, 4, 5) if s != size],
            [size],
            size_entry(0.9),
            [f"test_size={size}", "protocol=many_to_one"],
        )
    results_run(runs / "o2m" / "0", "one_to_many", [4], [3, 5], size_entry(0.5), ["train_size=4"])
    results_run(runs / "abl" / "0", "intra", [5], [5], size_entry(0.37), ["model=pe_random"])
    tables, md = _gather(runs, tmp_path / "out")
    assert set(tables["table2"]["GRACE"]) == {"intra", "many_to_one"}
    assert set(tables["table2"]["GRACE"]["many_to_one"]) == {"3", "4"}
    assert tables["table3"]["GRACE"]["4"]["5"]["seq_auc"]["mean"] == 0.5
    assert tables["table2"]["model=pe_random"]["intra"]["5"]["seq_auc"]["mean"] == 0.37
    assert len(tables["runs"]) == 5
    assert "intra A3 | intra A4 | intra A5 | many_to_one A3 | many_to_one A4 |" in md
    assert "| GRACE | A4 | 1.00 ± 0.00 | 1.00 ± 0.00 | 0.50 ± 0.01 | 0.50 ± 0.01 |" in md
    assert "| random | Complete Sequence AUC (paper: empty = 1) |" in md


def test_gather_puts_strict_figures_beside_the_papers(tmp_path, results_run, size_entry):
    stat = {"mean": 0.2, "std": 0.0, "assemblies": 277, "empty": 222}
    entry = size_entry(0.8, 0.9, p_at_k={"1": {**stat, "mean": 1.0}}, p_at_k_strict={"1": stat})
    results_run(tmp_path / "runs" / "0", "one_to_many", [5], [3], entry)
    results_run(tmp_path / "runs" / "1", "intra", [5], [3], entry)
    _, md = _gather(tmp_path / "runs", tmp_path / "out")
    assert "| Variant | Training set | step A3 | seq A3 | strict seq A3 | strict P@1 A3 |" in md
    assert "| GRACE | A5 | 0.90 ± 0.00 | 0.80 ± 0.01 | – | 0.20 ± 0.00 (222/277 empty) |" in md
    assert "| GRACE | P@1 (strict: empty = 0) | 0.20 ± 0.00 (222/277 empty) |" in md
    assert md.index("P@1 (strict") < md.index("| GRACE | P@1 (paper")


def test_missing_root_is_a_clear_error(tmp_path):
    with pytest.raises(UserError, match=r"task\.roots"):
        _gather(tmp_path / "nope", tmp_path)
    (tmp_path / "empty").mkdir()
    with pytest.raises(UserError, match=r"no results\.json found"):
        _gather(tmp_path / "empty", tmp_path)


def _self_train_run(
    folder, seed, labels, p_at_1, draw_seed=2, probe=None, own=False, model=(), kept=False,
    rule=None,
):  # fmt: skip
    """A self_train.json; `model` overrides in its settings, or with `kept` only in the
    .hydra/overrides.yaml beside it, as runs from before the setting have them; `rule`: the
    class of its `threshold=` rule (None: a run from before the setting)."""
    settings = {"labels": labels, "mask_unknown": True, "draw_seed": draw_seed, "seed": seed}
    if rule is not None:
        settings["threshold"] = {"_target_": f"grace.planning.thresholds.{rule}"}
    if model and not kept:
        settings["model"] = list(model)
    if probe is not None or seed:  # seed 0 runs stand for runs from before the setting existed
        settings["probe_checks"] = probe
    if own or seed:
        settings["probe_own_sequence"] = own
    test = {"8": {"p_at_1_strict": p_at_1, "no_sequence_share": 0.1}}
    rounds = [{"round": r, "added": 60 * r, "test": test} for r in range(2)]
    if own:  # runs from before the first choice was judged lack it
        rounds = [{**r, "first_choice": 0.3 + 0.1 * r["round"]} for r in rounds]
    (folder / ".hydra").mkdir(parents=True)
    (folder / "self_train.json").write_text(json.dumps({"settings": settings, "rounds": rounds}))
    if kept:
        lines = [f"- seed={seed}", *(f"- {o}" for o in model), "- paths.data_dir=/data"]
        (folder / ".hydra" / "overrides.yaml").write_text("\n".join(lines) + "\n")


def test_gather_pools_self_training_runs_over_seeds_per_label_source(tmp_path):
    _self_train_run(tmp_path / "runs" / "a", 0, "verified", 0.4)
    _self_train_run(tmp_path / "runs" / "b", 1, "verified", 0.6)
    _self_train_run(tmp_path / "runs" / "c", 0, "brute_force", 0.7)
    _self_train_run(tmp_path / "runs" / "e", 0, "verified", 0.8, probe=30)
    _self_train_run(tmp_path / "runs" / "f", 1, "verified", 0.6, probe=30)
    _self_train_run(tmp_path / "runs" / "g", 1, "verified", 0.9, probe=30, own=True)
    listwise = ["model/loss=listwise"]
    _self_train_run(tmp_path / "runs" / "h", 1, "verified", 0.2, probe=30, model=listwise)
    _self_train_run(
        tmp_path / "runs" / "i", 2, "verified", 0.4, probe=30, model=listwise, kept=True
    )
    out = tmp_path / "out"
    run(
        OmegaConf.create(
            {"task": {"roots": [str(tmp_path / "runs")]}, "paths": {"output_dir": str(out)}}
        )
    )
    md = (out / "self_train_gather.md").read_text()
    assert "| verified, masked | 1 | 2 | 60 | – | 0.50 ± 0.10 | 0.10 ± 0.00 |" in md
    assert "| brute_force | 0 | 1 | 0 | – | 0.70 ± 0.00 | 0.10 ± 0.00 |" in md
    assert "| verified, masked, probed (30 checks) | 1 | 2 | 60 | – | 0.70 ± 0.10 |" in md
    own = "probed (30 checks) and on its own sequence | 1 | 1 | 60 | 0.40 ± 0.00 | 0.90 ± 0.00 |"
    assert "on its own sequence | chosen (1) | 1 | 60 | 0.40 ± 0.00 |" in md
    assert md.count("chosen") == 1  # the other runs' rounds were not judged
    assert own in md
    assert (
        "| verified, masked, probed (30 checks) · model/loss=listwise | 1 | 2 | 60 | – | 0.30" in md
    )
    _self_train_run(tmp_path / "runs" / "d", 2, "verified", 0.6, draw_seed=5)
    with pytest.raises(UserError, match=r"self_train\.json: runs of 'verified, masked'"):
        _gather(tmp_path / "runs", out)


def test_self_training_runs_under_other_planning_rules_do_not_pool(tmp_path):
    """A run from before the rule was recorded planned under the paper's λ: it pools with a run
    naming that rule, not with one planned under the lifted rule."""
    runs, out = tmp_path / "runs", tmp_path / "out"
    _self_train_run(runs / "a", 0, "verified", 0.4)
    _self_train_run(runs / "b", 1, "verified", 0.6, rule="AbsoluteThreshold")
    cfg = {"task": {"roots": [str(runs)]}, "paths": {"output_dir": str(out)}}
    run(OmegaConf.create(cfg))
    assert (
        "| verified, masked | 1 | 2 | 60 | – | 0.50 ± 0.10 |"
        in (out / "self_train_gather.md").read_text()
    )
    _self_train_run(runs / "c", 2, "verified", 0.8, rule="LiftedThreshold")
    with pytest.raises(UserError, match=r"runs of 'verified, masked' labels differ"):
        run(OmegaConf.create(cfg))


def test_how_a_run_ran_makes_no_variant(tmp_path, results_run, size_entry):
    """Threads, data folder and the planner (which an experiment never reads) are `run` keys of
    an experiment: runs that differ only in them are one variant; the rule still makes one."""
    runs = tmp_path / "runs"
    results_run(runs / "a", "upward", [3], [8], size_entry(0.6), ["threads=2", "seed=0"])
    ran = ["threads=1", "paths.data_dir=/elsewhere", "planner.exhaustive_after=20", "seed=1"]
    results_run(runs / "b", "upward", [3], [8], size_entry(0.8), ran, 1)
    results_run(runs / "c", "upward", [3], [8], size_entry(0.7), ["threshold=relative"])
    tables, md = _gather(runs, tmp_path / "out")
    assert set(tables["table3"]) == {"GRACE (2 seeds)", "threshold=relative"}
    assert tables["table3"]["GRACE (2 seeds)"]["3"]["8"]["seq_auc"]["mean"] == pytest.approx(0.7)
    assert "## Table 3: upward" in md
