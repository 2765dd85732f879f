from planning_fakes import TableScorer, line_assembly

from grace.planning.prefix_cost import planner_benchmark, prefix_count


def test_prefix_count_matches_spec():
    assert prefix_count(7) == 8660


def test_benchmark_reports_both_paths(capsys):
    scorer = TableScorer(5, 0)
    result = planner_benchmark(scorer, line_assembly(5), repeats=1)
    assert result["sequences"] == 120 and result["distinct_passes"] == 31
    assert result["prefix_passes_measured"] == result["prefix_passes"] == prefix_count(5)
    assert scorer.states == 31 + prefix_count(5)
    assert "speed-up" in capsys.readouterr().out
