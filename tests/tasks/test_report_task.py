import shutil
from pathlib import Path

from omegaconf import OmegaConf

from grace.tasks.report import run

EXAMPLE = Path(__file__).parents[1] / "evaluation" / "book_example"


def test_task_report_writes_the_book_of_the_runs_under_its_roots(tmp_path, capsys):
    runs = tmp_path / "runs"
    shutil.copytree(EXAMPLE / "table3", runs)
    out = tmp_path / "out"
    run(OmegaConf.create({"task": {"roots": [str(runs)]}, "paths": {"output_dir": str(out)}}))
    book = (out / "report.md").read_text()
    assert book == capsys.readouterr().out.removesuffix("\n")
    assert "## One-to-many (paper Table 3)" in book and "Intra-sized" not in book
    assert "python -m grace --config-dir sweeps --config-name table3 -m train_size=4,5" in book
    assert "| GRACE | A4 | 0.95 ± 0.01 |" in book
