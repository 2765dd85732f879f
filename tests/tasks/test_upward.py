"""protocol=upward: trained on A3–A7, tested on larger sizes that never enter training or model
selection; its data generated through the data layer, its runs gathered into Table 3."""

import json

import numpy as np
import pytest
from omegaconf import OmegaConf, open_dict

from grace.cli.checks import protocol_split
from grace.evaluation.protocols import make_folds
from grace.tasks.experiment import run
from grace.tasks.gather import run as gather

TINY = "dataset.sizes={3: 6, 4: 6, 5: 6, 6: 6, 7: 6, 8: 4, 10: 4, 12: 4}"


def _upward_cfg(cfg_factory, fake_simulator, *overrides):
    """protocol=upward on FakeSimulator data of every size the protocol names, tiny counts."""
    cfg = cfg_factory(
        "protocol=upward", "scale=upward", TINY, "protocol.folds=2", "threads=1",
        "task.fold_jobs=1", "task.recording.per_size=0", "trainer.max_epochs=1",
        "trainer.enable_progress_bar=false", "model.net.hidden=8", *overrides,
    )  # fmt: skip
    with open_dict(cfg):
        cfg.simulator = fake_simulator
    return cfg


def test_upward_folds_keep_test_sizes_out_of_training_and_validation(cfg_factory):
    cfg = cfg_factory("protocol=upward", "scale=upward")
    sizes = [s for s, n in cfg.dataset.sizes.items() for _ in range(n)]
    proto = cfg.protocol
    train_sizes, test_sizes = protocol_split(proto, sizes)
    folds = make_folds(sizes, train_sizes, test_sizes, proto.folds, proto.val_fraction, proto.seed)
    assert train_sizes == [3, 4, 5, 6, 7] and test_sizes == [8, 10, 12]
    sizes = np.array(sizes)
    tested = []
    for fold in folds:
        assert set(sizes[list(fold.train + fold.val)]) == {3, 4, 5, 6, 7}
        assert set(sizes[list(fold.test)]) == {8, 10, 12}
        tested += fold.test
    assert sorted(tested) == list(np.flatnonzero(sizes >= 8))  # each tested once
    assert {s: (sizes == s).sum() for s in (8, 10, 12)} == {8: 100, 10: 100, 12: 100}


def test_more_training_assemblies_keep_the_test_set_and_halve_the_epochs(cfg_factory):
    """scale=upward_more: more A6 and A7 to train on, the same hundred A8, A10 and A12 to test
    (an assembly's draw depends on its size and index alone), and its own epoch count, which the
    command line still overrides."""
    upward = cfg_factory("protocol=upward", "scale=upward")
    more = cfg_factory("protocol=upward", "scale=upward_more")
    assert {n: more.dataset.sizes[n] for n in (8, 10, 12)} == {8: 100, 10: 100, 12: 100}
    assert all(more.dataset.sizes[n] >= upward.dataset.sizes[n] for n in upward.dataset.sizes)
    assert (more.dataset.sizes[6], more.dataset.sizes[7]) == (1000, 2000)
    assert (upward.trainer.max_epochs, more.trainer.max_epochs) == (16, 8)
    assert more.model.scheduler.T_max == 8  # the cosine schedule ends with the run
    again = cfg_factory("protocol=upward", "scale=upward_more", "trainer.max_epochs=3")
    assert again.trainer.max_epochs == 3


@pytest.mark.slow  # end to end; the split has its fast test above
def test_upward_runs_end_to_end_on_tiny_sizes(cfg_factory, fake_simulator, tmp_path):
    cfg = _upward_cfg(cfg_factory, fake_simulator)
    run(cfg)
    results = json.loads((tmp_path / "output" / "results.json").read_text())
    assert results["protocol"] == "upward" and results["test_sizes"] == [8, 10, 12]
    assert results["train_sizes"] == [3, 4, 5, 6, 7]
    for size in ("8", "10", "12"):
        entry = results["per_size"][size]
        assert entry["assemblies"] == 4  # every generated assembly of a test size, once
        # Planned exactly: every one of the 2^N - 1 non-complete states scored once.
        assert entry["forward_passes"] == 4 * (2 ** int(size) - 1)
        assert "confusion" in entry["feasibility"] and "placeable_auc_offpath" in entry
        for floor in ("constant", "never"):
            assert size in results["baselines"][floor]["per_size"]
    # FakeSimulator's A10 draws hold feasible assemblies: the sequence metrics are there too.
    assert {"1", "2", "3"} <= set(results["per_size"]["10"]["p_at_k_strict"])


def test_gather_extends_table3_by_the_upward_columns(tmp_path, results_run, size_entry):
    runs = tmp_path / "runs"
    floor = {"constant": size_entry(0.5)}
    results_run(runs / "o2m", "one_to_many", [5], [3, 4, 6, 7], size_entry(0.8), ["train_size=5"])
    strict = {"1": {"mean": 0.7, "std": 0.0, "assemblies": 90, "empty": 9}}
    results_run(
        runs / "up", "upward", [3, 4, 5, 6, 7], [8, 10, 12], size_entry(0.6, p_at_k_strict=strict),
        ["protocol=upward"], 0, floor,
    )  # fmt: skip
    out = tmp_path / "out"
    gather(OmegaConf.create({"task": {"roots": [str(runs)]}, "paths": {"output_dir": str(out)}}))
    md = (out / "gather.md").read_text()
    assert "| step A3 | step A4 | step A6 | step A7 | step A8 | step A10 | step A12 |" in md
    row = next(line for line in md.splitlines() if line.startswith("| GRACE | A3+4+5+6+7 |"))
    assert row.count("0.60 ± 0.01") == 3 and row.count("0.70 ± 0.00 (9/90 empty)") == 3
    # no figure of the four one-to-many test sizes (four columns each), nor of the strict
    # sequence AUC that the upward entries lack
    assert row.count("–") == 4 * 4 + 3
    # Every metric of the intra table, the floor's row beside GRACE's.
    lines = md[md.index("## Table 3, every metric") :].splitlines()
    at = lines.index(next(x for x in lines if x.startswith("| GRACE A3+4+5+6+7 | Complete")))
    assert lines[at + 1].startswith("| constant A3+4+5+6+7 | Complete Sequence AUC (paper: empty")
