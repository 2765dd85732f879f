import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_world_benchmark_command_composes_its_simulator_and_reports_each_size():
    out = subprocess.run(
        [sys.executable, "-m", "grace.simulation.world_timing", "3,4", "2", "boxes"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
        timeout=120,
    )
    report = json.loads(out.stdout)
    assert report["simulator"] == "boxes"
    assert [entry["size"] for entry in report["sizes"]] == [3, 4]
    assert all(entry["assemblies"] == 2 for entry in report["sizes"])
