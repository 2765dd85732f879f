"""results.json's typed records: the committed schema is the generated one, and a file written
by the records reads back to the same records, byte for byte."""

import json
import math

from grace.evaluation.report import aggregate
from grace.evaluation.results import (
    RESULTS,
    SCHEMA_FILE,
    ExperimentResults,
    PolicyResults,
    RunInfo,
    StageSeconds,
    read_results,
    schema_text,
    to_json,
)


def test_the_committed_schema_is_the_generated_one():
    assert SCHEMA_FILE.read_text() == schema_text(), (
        "regenerate it: python -m grace.evaluation.results > docs/results-schema.json"
    )
    schema = json.loads(schema_text())
    assert schema["title"] == "ExperimentResults"
    size = schema["$defs"]["SizeSummary"]
    assert "seq_auc" in size["properties"] and "seq_auc" not in size["required"]
    assert "Strict P@k" in size["properties"]["p_at_k_strict"]["description"]


def test_a_written_file_reads_back_to_the_same_records(tmp_path):
    fold = {
        "assemblies": 2,
        "passes": 14,
        "step_auc": 0.9,
        "step_auc_offpath": math.nan,
        "offpath_states": 0,
        "seq_auc": 0.8,
        "p_at_k": {"1": {"value": 1.0, "assemblies": 2, "empty": 1}},
        "p_at_k_strict": {"1": {"value": 0.5, "assemblies": 2, "empty": 1}},
        "no_sequence": 1,
        "feasibility": {"confusion": {"tp": 1, "fp": 0, "tn": 0, "fn": 1}, "schemes": {}},
    }
    per_size = aggregate([{3: fold}])
    results = ExperimentResults(
        protocol="intra",
        train_sizes=[3],
        test_sizes=[3],
        folds=2,
        per_size=per_size,
        baselines={"never": PolicyResults(per_size)},
        seconds=2.0,
        seconds_by_stage=StageSeconds(0.5, [1.0], [0.5]),
        run=RunInfo(model="grace", seed=0, data_seed=None, overrides=["seed=0"]),
    )
    text = to_json(results, RESULTS)
    (tmp_path / "results.json").write_text(text)
    again = read_results(tmp_path / "results.json")
    assert again == results and to_json(again, RESULTS) == text
    written = json.loads(text)
    assert "step_auc_offpath" not in written["per_size"]["3"]  # undefined: absent, not zero
    assert written["run"]["data_seed"] is None  # raw data: null, as before
