import json

import pytest
from omegaconf import OmegaConf

from grace.errors import UserError
from grace.tasks.gather import run, variants


def _write(path, protocol, train, test, seq, overrides=(), seed=0):
    entry = {"step_auc": {"mean": 1.0, "std": 0.0}, "seq_auc": {"mean": seq, "std": 0.01}}
    results = {
        "protocol": protocol,
        "train_sizes": train,
        "test_sizes": test,
        "folds": 4,
        "per_size": {str(s): entry for s in test},
        "baselines": {
            "random": {"per_size": {str(s): {"step_auc": entry["step_auc"]} for s in test}}
        },
        "seconds": 1.0,
        "run": {"seed": seed, "overrides": list(overrides)},
    }
    path.mkdir(parents=True)
    (path / "results.json").write_text(json.dumps(results))


def test_gather_builds_table2_and_table3(tmp_path):
    runs = tmp_path / "multirun"
    _write(runs / "intra" / "0", "intra", [3, 4, 5], [3, 4, 5], 0.97)
    for i, size in enumerate((3, 4)):
        _write(
            runs / "m2o" / str(i),
            "many_to_one",
            [s for s in (3, 4, 5) if s != size],
            [size],
            0.9,
            [f"test_size={size}", "protocol=many_to_one"],
        )
    _write(runs / "o2m" / "0", "one_to_many", [4], [3, 5], 0.5, ["train_size=4"])
    _write(runs / "abl" / "0", "intra", [5], [5], 0.37, ["model=pe_random"])
    out = tmp_path / "out"
    cfg = OmegaConf.create({"task": {"roots": [str(runs)]}, "paths": {"output_dir": str(out)}})
    run(cfg)
    tables = json.loads((out / "gather.json").read_text())
    assert set(tables["table2"]["GRACE"]) == {"intra", "many_to_one"}
    assert set(tables["table2"]["GRACE"]["many_to_one"]) == {"3", "4"}
    assert tables["table3"]["GRACE"]["4"]["5"]["seq_auc"]["mean"] == 0.5
    assert tables["table2"]["model=pe_random"]["intra"]["5"]["seq_auc"]["mean"] == 0.37
    md = (out / "gather.md").read_text()
    assert "intra A3 | intra A4 | intra A5 | many_to_one A3 | many_to_one A4 |" in md
    assert "| GRACE | A4 | 1.00 ± 0.00 | 1.00 ± 0.00 | 0.50 ± 0.01 | 0.50 ± 0.01 |" in md
    assert "| random | Complete Sequence AUC |" in md


def test_variant_is_what_differs_between_runs():
    runs = [
        {"run": {"overrides": ["scale=paper", "protocol=intra", "model=grace"]}},
        {"run": {"overrides": ["scale=paper", "test_size=5", "model=pe_none"]}},
        {"run": {"overrides": ["scale=paper"]}},
    ]
    assert variants(runs) == ["model=grace", "model=pe_none", "GRACE"]
    assert variants(runs[:1]) == ["GRACE"]
    seeds = [{"run": {"overrides": ["seed=1", "dataset.seed=0"]}}, {"run": {"overrides": []}}]
    assert variants(seeds) == ["GRACE", "GRACE"]  # seeds repeat a run, they are no variant


def test_missing_root_is_a_clear_error(tmp_path):
    cfg = OmegaConf.create(
        {"task": {"roots": [str(tmp_path / "nope")]}, "paths": {"output_dir": str(tmp_path)}}
    )
    with pytest.raises(UserError, match=r"task\.roots"):
        run(cfg)


def test_runs_that_differ_only_in_seed_are_pooled(tmp_path):
    """Two seeds of one variant: one block, the mean ± std over the runs' means, counts summed;
    a variant with one seed stays as it was; the baseline, in every run, counts each seed once."""
    runs = tmp_path / "multirun"
    for seed, seq in ((0, 0.9), (1, 0.8)):
        _write(runs / f"s{seed}", "intra", [5], [5], seq, [f"seed={seed}", "model=grace"], seed)
        results = json.loads((runs / f"s{seed}" / "results.json").read_text())
        entry = results["per_size"]["5"]
        entry["no_sequence"] = 3
        entry["p_at_k_strict"] = {"1": {"mean": seq, "std": 0.1, "assemblies": 20, "empty": 3}}
        (runs / f"s{seed}" / "results.json").write_text(json.dumps(results))
    _write(runs / "other", "intra", [5], [5], 0.5, ["seed=0", "model=pe_none"])
    out = tmp_path / "out"
    cfg = OmegaConf.create({"task": {"roots": [str(runs)]}, "paths": {"output_dir": str(out)}})
    run(cfg)
    table2 = json.loads((out / "gather.json").read_text())["table2"]
    assert set(table2) == {"model=grace (2 seeds)", "model=pe_none", "random (2 seeds)"}
    pooled = table2["model=grace (2 seeds)"]["intra"]["5"]
    assert pooled["seq_auc"] == pytest.approx({"mean": 0.85, "std": 0.05, "runs": 2})
    assert pooled["p_at_k_strict"]["1"]["empty"] == 6
    assert pooled["p_at_k_strict"]["1"]["assemblies"] == 40
    assert pooled["no_sequence"] == 6
    assert table2["model=pe_none"]["intra"]["5"]["seq_auc"] == {"mean": 0.5, "std": 0.01}
    md = (out / "gather.md").read_text()
    assert "| model=grace (2 seeds) | Complete Sequence AUC | 0.85 ± 0.05 |" in md
