import json
import math

from grace.evaluation.report import aggregate, mean_std, results_markdown, write_results
from grace.evaluation.results import (
    Confusion,
    CountedStat,
    ExperimentResults,
    FoldHealth,
    PolicyResults,
    SizeHealth,
    StageSeconds,
    Stat,
    plain,
    read_results,
)


def _scheme(auc, tpr):
    return {"roc_auc": auc, "tpr_at_fpr": tpr, "roc": None, "assemblies": 4, "feasible": 3}


def _fold(step, seq, p1, strict=None, offpath=math.nan, best=math.nan):
    return {
        "assemblies": 4,
        "passes": 31,
        "step_auc": step,
        "step_auc_offpath": offpath,
        "offpath_states": 5,
        "seq_auc": seq,
        "p_at_k": {
            "1": {"value": p1, "assemblies": 2, "empty": 1},
            "3": {"value": math.nan, "assemblies": 0, "empty": 0},
        },
        "p_at_k_strict": {
            "1": {"value": p1 - 0.5 if strict is None else strict, "assemblies": 2, "empty": 1},
            "3": {"value": math.nan, "assemblies": 0, "empty": 0},
        },
        "no_sequence": 1,
        "feasibility": {
            "confusion": {"tp": 2, "fp": 0, "tn": 1, "fn": 1},
            "schemes": {"best_sequence": _scheme(best, 0.5)},
        },
    }


def test_mean_std_skips_undefined_values():
    assert mean_std([1.0, math.nan, 0.5]) == Stat(mean=0.75, std=0.25)
    assert mean_std([math.nan]) is None


def test_aggregate_keeps_sizes_as_strings_and_drops_undefined_metrics():
    per_size = aggregate(
        [{5: _fold(1.0, 0.9, 1.0), 3: _fold(0.8, math.nan, 0.5)}, {5: _fold(0.8, 0.7, 0.0)}]
    )
    assert list(per_size) == ["3", "5"]
    five = per_size["5"]
    assert five.step_auc.mean == 0.9 and abs(five.step_auc.std - 0.1) < 1e-12
    assert five.p_at_k["1"] == CountedStat(mean=0.5, std=0.5, assemblies=4, empty=2)
    assert five.p_at_k_strict["1"] == CountedStat(mean=0.0, std=0.5, assemblies=4, empty=2)
    assert "3" not in five.p_at_k  # undefined in every fold: absent, not zero
    written = {size: plain(entry) for size, entry in per_size.items()}
    assert "seq_auc" not in written["3"] and "step_auc_offpath" not in written["5"]
    assert "schemes" not in written["5"]["feasibility"]  # every scheme undefined
    assert "runs" not in written["5"]["step_auc"]  # a fold mean, not a pooled one
    assert five.feasibility.confusion == Confusion(tp=4, fp=0, tn=2, fn=2)
    assert five.folds == 2 and per_size["3"].folds == 1
    assert five.forward_passes == 62 and five.offpath_states == 10


def test_offpath_and_feasibility_schemes_aggregate_over_folds():
    folds = [
        {5: _fold(1.0, 0.9, 1.0, offpath=0.6, best=0.9)},
        {5: _fold(1.0, 0.9, 1.0, offpath=0.8, best=0.7)},
    ]
    five = aggregate(folds)["5"]
    assert abs(five.step_auc_offpath.mean - 0.7) < 1e-12
    scheme = five.feasibility.schemes["best_sequence"]
    assert abs(scheme.roc_auc.mean - 0.8) < 1e-12 and scheme.tpr_at_fpr.mean == 0.5


def _results(per_size, **extra):
    return ExperimentResults(
        protocol="intra",
        train_sizes=[5],
        test_sizes=[5],
        folds=2,
        per_size=per_size,
        baselines={"random": PolicyResults(per_size)},
        seconds=1.5,
        seconds_by_stage=StageSeconds(load=0.5, train=[0.5], evaluate=[0.5]),
        **extra,
    )


def test_results_files_lead_with_strict_figures(tmp_path):
    per_size = aggregate(
        [{5: _fold(1.0, 0.96, 0.95, best=0.9)}, {5: _fold(1.0, 0.94, 0.95, best=0.8)}]
    )
    results = _results(per_size)
    write_results(results, tmp_path)
    assert read_results(tmp_path / "results.json") == results
    assert "run" not in json.loads((tmp_path / "results.json").read_text())  # none given
    md = (tmp_path / "results.md").read_text()
    assert "| GRACE | Complete Sequence AUC | 0.95 ± 0.01 |" in md
    assert "| GRACE | P@1 (strict: empty = 0) | 0.45 ± 0.00 (2/4 empty) |" in md
    assert "| GRACE | P@1 (paper: empty = 1) | 0.95 ± 0.00 (2/4 empty) |" in md
    assert md.index("P@1 (strict") < md.index("Step-by-Step AUC |") < md.index("P@1 (paper")
    assert "| GRACE | P@3 (paper: empty = 1) | – |" in md
    assert "| best_sequence | 0.85 ± 0.05 / 0.50 |" in md  # the feasibility table
    assert md == results_markdown(results)
    assert not list(tmp_path.glob(".*tmp"))


def test_collapsed_folds_are_impossible_to_miss():
    per_size = aggregate([{5: _fold(0.3, 0.4, 0.5)}])
    health = [
        FoldHealth(fold=0, sizes={"5": SizeHealth(step_auc=0.9, floor=0.6)}),
        FoldHealth(
            fold=1,
            collapsed=True,
            reasons=["A5 test step AUC 0.300 ≤ floor 0.600"],
            sizes={"5": SizeHealth(step_auc=0.3, floor=0.6)},
        ),
    ]
    md = results_markdown(_results(per_size, collapsed_folds=[1], fold_health=health))
    assert "**Warning: folds [1] collapsed**" in md
    assert "- fold 1: **COLLAPSED**: A5 test step AUC 0.300 ≤ floor 0.600." in md
    assert "- fold 0: ok." in md
    assert "Warning" not in results_markdown(_results(per_size, collapsed_folds=[]))
