"""search_bench.md: the summary's figures as tables, one row per planner and size."""

from grace.evaluation.search_bench import AssemblyRuns, PlannerRun, search_bench_markdown, summarise


def run(outcome: str, checks: int, first: int | None) -> PlannerRun:
    return PlannerRun(outcome, checks, 1.5, first, None if first is None else 1.25)


def test_the_tables_carry_the_summary_figures_of_each_kind():
    records = [
        AssemblyRuns("A30-0", 30, True, None, {"grace": run("verified", 40, 40)}),
        AssemblyRuns("A30-1", 30, True, None, {"grace": run("verified", 90, 90)}),
        AssemblyRuns(
            "A12-0",
            12,
            False,
            600,
            {
                "grace": run("infeasible", 0, None),
                "brute_force": PlannerRun("infeasible", 600, 0.5, None, None),
            },
        ),
        AssemblyRuns("A50-0", 50, None, None, {"grace": run("not found within budget", 9, None)}),
    ]
    text = search_bench_markdown(summarise(records, [1, 2], "grace"))
    lines = text.splitlines()
    assert "| size (feasible) | planner | 1N | 2N | unlimited | median checks | median s |" in lines
    # no order within 30 checks, one of two within 60, both unlimited; median of 40 and 90
    assert "| A30 (2) | grace | 0.00 | 0.50 | 1.00 | 65 | 1.25 |" in lines
    # a proof without a step check: ∞ fewer checks; three times the brute force's seconds
    assert "| A12 (1) | grace | 1.00 | 0 | 1.50 | ∞ | 3.00 |" in lines
    assert "| A50 (1) | grace | not found within budget 1 | 1.50 |" in lines
