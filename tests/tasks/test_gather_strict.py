import json

from omegaconf import OmegaConf

from grace.tasks.gather import run


def test_gather_puts_strict_figures_beside_the_papers(tmp_path):
    stat = {"mean": 0.2, "std": 0.0, "assemblies": 277, "empty": 222}
    entry = {
        "step_auc": {"mean": 0.9, "std": 0.0},
        "seq_auc": {"mean": 0.8, "std": 0.0},
        "p_at_k": {"1": {**stat, "mean": 1.0}},
        "p_at_k_strict": {"1": stat},
    }
    results = {
        "protocol": "one_to_many",
        "train_sizes": [5],
        "test_sizes": [3],
        "folds": 4,
        "per_size": {"3": entry},
        "baselines": {},
        "seconds": 1.0,
        "run": {"overrides": []},
    }
    (tmp_path / "runs" / "0").mkdir(parents=True)
    (tmp_path / "runs" / "0" / "results.json").write_text(json.dumps(results))
    results["protocol"] = "intra"
    (tmp_path / "runs" / "1").mkdir()
    (tmp_path / "runs" / "1" / "results.json").write_text(json.dumps(results))
    out = tmp_path / "out"
    run(
        OmegaConf.create(
            {"task": {"roots": [str(tmp_path / "runs")]}, "paths": {"output_dir": str(out)}}
        )
    )
    md = (out / "gather.md").read_text()
    assert "| Variant | Training set | step A3 | seq A3 | strict P@1 A3 |" in md
    assert "| GRACE | A5 | 0.90 ± 0.00 | 0.80 ± 0.00 | 0.20 ± 0.00 (222/277 empty) |" in md
    assert "| GRACE | P@1 (strict: empty = 0) | 0.20 ± 0.00 (222/277 empty) |" in md
    assert md.index("P@1 (strict") < md.index("| GRACE | P@1 (paper")
