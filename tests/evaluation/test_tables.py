from grace.evaluation.tables import size_diagnosis_table


def _group(median: float, share: float) -> dict:
    return {"count": 4, "quantiles": [0.0, 0.1, median, 0.9, 1.0], "at_or_above_threshold": share}


def test_size_diagnosis_table_reads_medians_shares_and_the_growth_past_training():
    scores = {
        size: {
            "onpath": {"valid": _group(0.9 - 0.2 * i, 1 - 0.25 * i), "invalid": {"count": 0}},
            "offpath": {"valid": _group(0.5, 0.5), "invalid": _group(0.0, 0.0)},
        }
        for i, size in enumerate(("5", "7", "9"))
    }
    activations = {"5": {"placed_sum": {"mean": 1.0}}, "7": {"placed_sum": {"mean": 2.0}}}
    activations["9"] = {"placed_sum": {"mean": 3.0}}
    report = {"train_sizes": [5, 7], "scores": scores, "activations": activations}
    lines = size_diagnosis_table(report).splitlines()
    assert lines[0] == "|  | A5 | A7 | A9 | A9 ÷ A7 |"
    valid = "| valid parts, on the true orders (median / ≥ λ) |"
    assert lines[2] == valid + " 0.90 / 1.00 | 0.70 / 0.75 | 0.50 / 0.50 |  |"
    assert lines[3].startswith("| invalid parts, on the true orders (median / ≥ λ) | – | – | – |")
    assert lines[-1] == "| `placed_sum` | 1.00 | 2.00 | 3.00 | 1.50 |"
