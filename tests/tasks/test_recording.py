"""An experiment's sequences.rrd, read back with rerun's own reader, and task=replay."""

from __future__ import annotations

import pytest
from omegaconf import open_dict
from recording_fakes import wrong_first_part

from grace.tasks.experiment import run
from grace.tasks.replay import run as replay
from grace.visualisation.recording import summarise, text_entries

PER_ASSEMBLY = ("sequences", "step", "scores", "cell/parts", "cell/clamps", "cell/tool")


def test_experiment_recording_holds_sequences_cell_and_the_known_failure(
    tmp_path, fake_cfg, cfg_factory, capsys
):
    out = tmp_path / "run"
    cfg = fake_cfg(out, "intra", "task.recording.per_size=2", "task.recording.top_k=2")
    with open_dict(cfg):
        cfg.task.scorer = {"_target_": "recording_fakes.make_scorer", "_partial_": True}
    run(cfg)
    rrd = out / "sequences.rrd"
    summary = summarise(rrd)
    roots = sorted({e.rsplit("/", 1)[0] for e in summary.entities if e.endswith("/sequences")})
    # 4 folds x sizes 3, 4, 5 x 2 assemblies per size
    assert len(roots) == 4 * 3 * 2
    assert {r.split("/")[1] for r in roots} == {f"fold_{k}" for k in range(4)}
    for root in roots:
        size = int(root.split("/")[2][1:])
        for entity in PER_ASSEMBLY:
            assert f"{root}/{entity}" in summary.entities, f"{root}/{entity}"
        assert summary.entities[f"{root}/sequences"].static
        assert summary.entities[f"{root}/step"].timelines == {"step"}
        assert summary.entities[f"{root}/scores"].rows == size  # one bar chart per step
    assert summary.steps == (0, 4)

    failures = text_entries(rrd, "/failures")
    for root in roots:
        name = root.rsplit("/", 1)[1]
        wrong = wrong_first_part(name)
        mine = [(step, text) for entity, step, text in failures if entity.startswith(root + "/")]
        if wrong is None:
            continue  # the policy is the oracle here: its top sequence may still fail later
        # the rank-1 sequence starts with the wrong part: a failure entry at step 0 names it
        assert (0, f"rank 1, step 0: part {wrong} leaves the ground truth") in [
            (step, text.split(";")[0]) for step, text in mine
        ]
        assert f"{root}/cell/failure" in summary.entities
    assert any(wrong_first_part(r.rsplit("/", 1)[1]) is not None for r in roots)

    replay(cfg_factory("task=replay", f"path={out}"))
    printed = capsys.readouterr().out
    assert f"{rrd}: 24 assemblies" in printed and "no display" in printed


@pytest.mark.slow  # a fast twin covers the behaviour; this one is end to end
def test_no_recording_when_switched_off(tmp_path, fake_cfg):
    out = tmp_path / "run"
    run(fake_cfg(out, "intra", "task.recording.per_size=0"))
    assert not (out / "sequences.rrd").exists() and (out / "results.json").exists()
