from dataclasses import replace

import matplotlib.image

from grace.evaluation.failures import FalseStep, failure_histogram, failures_report
from grace.evaluation.feasibility_schemes import add_schemes, feasibility_report, scheme_summary
from grace.evaluation.results import Confusion, CountedStat, FeasibilitySummary, SizeSummary
from grace.visualisation.plots import p_at_k_bars
from grace.visualisation.side_file_plots import draw_side_files


def _reports(sizes):
    folds = [{}]
    feasible = [True, True, False, True]
    for size in sizes:
        add_schemes(
            folds[0], {"best_sequence": {size: scheme_summary(feasible, [0.9, 0.7, 0.8, 0.1])}}
        )
        add_schemes(
            folds[0], {"bottleneck": {size: scheme_summary(feasible, [0.9, 0.7, 0.2, 0.6])}}
        )
        steps = [FalseStep(0, 1, 1, 0.95, 12), FalseStep(3, 2, 3, 0.55, 2)]
        folds[0][size]["failures"] = {
            "feasible": failure_histogram(steps, 0.5),
            "infeasible": failure_histogram([FalseStep(0, 0, 1, 0.7, 24)], 0.5),
        }
    return {"feasibility": feasibility_report(folds), "failures": failures_report(folds)}


def test_analysis_figures_get_a_panel_per_size(tmp_path):
    for sizes, folder in (([5], tmp_path / "one"), ([5, 6, 7], tmp_path / "three")):
        folder.mkdir()
        draw_side_files(_reports(sizes), folder)
    for name in ("feasibility_roc.png", "failures.png"):
        one = matplotlib.image.imread(tmp_path / "one" / name)
        three = matplotlib.image.imread(tmp_path / "three" / name)
        assert three.shape[1] > 1.5 * one.shape[1]  # a panel column per test size


def test_p_at_k_bars_draw_strict_and_paper_values(tmp_path):
    stat = CountedStat(mean=0.6, std=0.1, assemblies=10, empty=3)
    counts = {"folds": 1, "assemblies": 10, "forward_passes": 0, "offpath_states": 0}
    feasibility = FeasibilitySummary(Confusion(tp=7, fp=0, tn=0, fn=3))
    empty = SizeSummary(**counts, no_sequence=3, feasibility=feasibility)
    entry = replace(empty, p_at_k={"1": replace(stat, mean=0.9)}, p_at_k_strict={"1": stat})
    p_at_k_bars({"GRACE": {"5": entry}, "never": {"5": empty}}, tmp_path / "p.png")
    assert matplotlib.image.imread(tmp_path / "p.png").shape[0] > 100
