import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow  # a fast twin covers the behaviour; this one is end to end
def test_the_comparison_labels_the_same_frames_with_every_simulator(tmp_path):
    out = tmp_path / "run"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "grace",
            "task=compare_simulators",
            "dataset.sizes={4: 3}",
            f"paths.data_dir={tmp_path}",
            f"paths.output_dir={out}",
        ],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
        timeout=300,
    )
    report = json.loads((out / "simulators.json").read_text())
    assert set(report) == {"4"} and report["4"]["assemblies"] == 3
    assert set(report["4"]["infeasible_fraction"]) == {"dual_arm", "single_arm", "boxes"}
    table = (out / "simulators.md").read_text().splitlines()
    assert table[0].startswith("| size | assemblies | infeasible dual_arm")
    assert table[2].startswith("| A4 | 3 |") and len(table) == 3
