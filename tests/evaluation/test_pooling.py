import json

import pytest

from grace.errors import UserError
from grace.evaluation.gather import collect, find_results, gather_markdown, variants
from grace.evaluation.results import ExperimentResults, RunInfo, plain


def _run(*overrides):
    results = ExperimentResults("intra", [5], [5], 4, {}, {}, 1.0, None)
    results.run = RunInfo(overrides=list(overrides))
    return results


def test_variant_is_what_differs_between_runs():
    runs = [
        _run("scale=paper", "protocol=intra", "model=grace", "paths.output_dir=runs/a"),
        _run("scale=paper", "test_size=5", "model=pe_none", "hydra.run.dir=runs/b"),
        _run("scale=paper"),
    ]
    assert variants(runs) == ["model=grace", "model=pe_none", "GRACE"]
    assert variants(runs[:1]) == ["GRACE"]
    seeds = [_run("seed=1", "dataset.seed=0"), _run()]
    assert variants(seeds) == ["GRACE", "GRACE"]  # seeds repeat a run, they are no variant


def test_runs_that_differ_only_in_seed_are_pooled(tmp_path, results_run, size_entry):
    """Two seeds of one variant: one block, the mean ± std over the runs' means, counts summed;
    a variant with one seed stays as it was; the baseline, in every run, counts each seed once."""
    runs = tmp_path / "multirun"
    random = {"random": size_entry(0.5)}
    for seed, seq in ((0, 0.9), (1, 0.8)):
        strict = {"1": {"mean": seq, "std": 0.1, "assemblies": 20, "empty": 3}}
        entry = size_entry(seq, no_sequence=3, p_at_k_strict=strict)
        overrides = [f"seed={seed}", "model=grace"]
        results_run(runs / f"s{seed}", "intra", [5], [5], entry, overrides, seed, random)
    results_run(runs / "other", "intra", [5], [5], size_entry(0.5), ["seed=0", "model=pe_none"])
    gathered = collect(find_results([runs]))
    table2 = json.loads(json.dumps(plain(gathered)))["table2"]
    assert set(table2) == {"model=grace (2 seeds)", "model=pe_none", "random (2 seeds)"}
    pooled = table2["model=grace (2 seeds)"]["intra"]["5"]
    assert pooled["seq_auc"] == pytest.approx({"mean": 0.85, "std": 0.05, "runs": 2})
    assert pooled["p_at_k_strict"]["1"]["empty"] == 6
    assert pooled["p_at_k_strict"]["1"]["assemblies"] == 40
    assert pooled["no_sequence"] == 6 and pooled["folds"] == 8
    assert table2["model=pe_none"]["intra"]["5"]["seq_auc"] == {"mean": 0.5, "std": 0.01}
    assert (
        "| model=grace (2 seeds) | Complete Sequence AUC (paper: empty = 1) | 0.85 ± 0.05 |"
        in gather_markdown(gathered)
    )


def test_a_malformed_results_file_names_the_file_and_field(tmp_path, results_run, size_entry):
    folder = results_run(tmp_path / "run", "intra", [5], [5], size_entry(0.9))
    results = json.loads((folder / "results.json").read_text())
    results["per_size"]["5"]["seq_auc"]["mean"] = "high"
    (folder / "results.json").write_text(json.dumps(results))
    with pytest.raises(UserError, match=r"results\.json: field 'per_size\.5\.seq_auc\.mean'"):
        collect([folder / "results.json"])


def test_a_re_planned_run_is_its_rule_and_its_floors_are_that_rule_s(
    tmp_path, results_run, size_entry
):
    """The same weights re-planned under the relative rule (`task.checkpoints`): the variant is
    the rule, not the weights' path, and each rule's floor keeps its own figures."""
    runs = tmp_path / "runs"
    results_run(
        runs / "abs", "upward", [3], [8], size_entry(0.6), ["seed=0"], 0,
        {"constant": size_entry(0.0)},
    )  # fmt: skip
    replanned = ["seed=0", f"task.checkpoints={runs / 'abs'}", "threshold=relative"]
    results_run(
        runs / "rel", "upward", [3], [8], size_entry(0.7), replanned, 0,
        {"constant": size_entry(0.5)},
    )  # fmt: skip
    gathered = collect(find_results([runs]))
    assert "## Table 3: upward\n" in gather_markdown(gathered)
    table3 = json.loads(json.dumps(plain(gathered)))["table3"]
    assert set(table3) == {
        "GRACE",
        "threshold=relative",
        "constant",
        "constant (threshold=relative)",
    }
    assert table3["constant"]["3"]["8"]["seq_auc"]["mean"] == 0.0
    assert table3["constant (threshold=relative)"]["3"]["8"]["seq_auc"]["mean"] == 0.5
    assert table3["threshold=relative"]["3"]["8"]["seq_auc"]["mean"] == 0.7
