"""The results book of task=report against a stored example: seven tiny run folders
(book_example/: two seeds of the `seeds` sweep, two models of the `ablation` sweep under the joblib
launcher, two runs of the `table3` sweep and one many-to-one run from a plain command line, each
with its results.json and Hydra's `.hydra` records) and the markdown they must give
(book_example.md, checked by hand: e.g. the two seeds' strict P@1 0.94 and 0.92 pool to
0.93 ± 0.01 with 2 of 16 assemblies empty)."""

from pathlib import Path

from grace.evaluation.book import commands, results_book
from grace.evaluation.gather import find_results

EXAMPLE = Path(__file__).parent / "book_example"
REPORT = "python -m grace task=report 'task.roots=[tests/evaluation/book_example]'"


def test_the_book_reproduces_the_stored_example():
    book = results_book(find_results([EXAMPLE]), REPORT)
    assert book == EXAMPLE.with_suffix(".md").read_text()


def test_runs_of_a_full_product_make_one_sweep_and_others_one_line_each():
    sweep = ("--config-dir", "sweeps", "--config-name", "table3")
    product = [(sweep, (f"train_size={t}", f"model={m}")) for t in (4, 5) for m in ("a", "b")]
    assert commands(product) == [
        "python -m grace --config-dir sweeps --config-name table3 -m train_size=4,5 model=a,b"
    ]
    partial = [((), ("seed=0", "model=a")), ((), ("seed=1", "model=b"))]
    assert commands(partial) == [
        "python -m grace seed=0 model=a",
        "python -m grace seed=1 model=b",
    ]
    commas = [((), ("protocol.train_sizes=[3,4]",)), ((), ("protocol.train_sizes=[5]",))]
    assert commands(commas) == [
        "python -m grace 'protocol.train_sizes=[3,4]'",
        "python -m grace 'protocol.train_sizes=[5]'",
    ]
    assert commands([((), ("seed=0",)), ((), ("seed=0",))]) == ["python -m grace seed=0"]
