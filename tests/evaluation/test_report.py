import json
import math

from grace.evaluation.report import aggregate, mean_std, results_markdown, write_results


def _fold(step, seq, p1, roc=math.nan):
    return {
        "assemblies": 4,
        "passes": 31,
        "step_auc": step,
        "seq_auc": seq,
        "p_at_k": {
            "1": {"value": p1, "assemblies": 2, "empty": 1},
            "3": {"value": math.nan, "assemblies": 0, "empty": 0},
        },
        "no_sequence": 1,
        "feasibility": {"roc_auc": roc, "confusion": {"tp": 2, "fp": 0, "tn": 1, "fn": 1}},
    }


def test_mean_std_skips_undefined_values():
    assert mean_std([1.0, math.nan, 0.5]) == {"mean": 0.75, "std": 0.25}
    assert mean_std([math.nan]) is None


def test_aggregate_keeps_sizes_as_strings_and_drops_undefined_metrics():
    per_size = aggregate(
        [{5: _fold(1.0, 0.9, 1.0), 3: _fold(0.8, math.nan, 0.5)}, {5: _fold(0.8, 0.7, 0.0)}]
    )
    assert list(per_size) == ["3", "5"]
    five = per_size["5"]
    assert five["step_auc"]["mean"] == 0.9 and abs(five["step_auc"]["std"] - 0.1) < 1e-12
    assert five["p_at_k"]["1"] == {"mean": 0.5, "std": 0.5, "assemblies": 4, "empty": 2}
    assert "3" not in five["p_at_k"]  # undefined in every fold: absent, not zero
    assert "seq_auc" not in per_size["3"] and "roc_auc" not in five["feasibility"]
    assert five["feasibility"]["confusion"] == {"tp": 4, "fp": 0, "tn": 2, "fn": 2}
    assert five["folds"] == 2 and per_size["3"]["folds"] == 1
    assert five["forward_passes"] == 62


def test_results_files_in_paper_layout(tmp_path):
    per_size = aggregate([{5: _fold(1.0, 0.96, 0.95)}, {5: _fold(1.0, 0.94, 0.95)}])
    results = {
        "protocol": "intra",
        "train_sizes": [5],
        "test_sizes": [5],
        "folds": 2,
        "per_size": per_size,
        "baselines": {"random": {"per_size": per_size}},
        "seconds": 1.5,
    }
    write_results(results, tmp_path)
    assert json.loads((tmp_path / "results.json").read_text()) == results
    md = (tmp_path / "results.md").read_text()
    assert "| GRACE | Complete Sequence AUC | 0.95 ± 0.01 |" in md
    assert "| GRACE | P@3 | – |" in md
    assert md == results_markdown(results)
    assert not list(tmp_path.glob(".*tmp"))


def test_classifier_row_appears_only_with_a_classifier(tmp_path):
    with_classifier = [_fold(1.0, 0.9, 1.0), _fold(1.0, 0.9, 1.0)]
    for fold, value in zip(with_classifier, (0.8, 0.6), strict=True):
        fold["feasibility"]["classifier_roc_auc"] = value
    results = {
        "protocol": "intra",
        "train_sizes": [5],
        "test_sizes": [5],
        "folds": 2,
        "baselines": {},
        "seconds": 1.0,
    }
    plain = results_markdown({**results, "per_size": aggregate([{5: _fold(1.0, 0.9, 1.0)}])})
    assert "(classifier)" not in plain
    per_size = aggregate([{5: fold} for fold in with_classifier])
    stat = per_size["5"]["feasibility"]["classifier_roc_auc"]
    assert abs(stat["mean"] - 0.7) < 1e-12 and abs(stat["std"] - 0.1) < 1e-12
    assert "| GRACE | Feasibility ROC AUC (classifier) | 0.70 ± 0.10 |" in results_markdown(
        {**results, "per_size": per_size}
    )
