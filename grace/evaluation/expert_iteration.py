"""Expert iteration ("self-training", docs/size-generalisation.md): label larger assemblies with
the verified search and the current model, retrain on the original set plus every assembly
labelled so far, score, repeat. The rounds of task=self_train (grace/tasks/self_train.py), with
the training, the draws and the scoring given as functions."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from typing import Any

from grace.domain.assembly import Assembly
from grace.domain.sample import LabelledAssembly
from grace.evaluation.self_train import Labels, RoundFigures
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.fixation_prior import FixationPrior
from grace.planning.search import VerifiedSearch
from grace.planning.self_labels import (
    plan_labels,
    probe_steps,
    search_negatives,
    verified_orders,
)
from grace.planning.sequences import Scorer

log = logging.getLogger(__name__)


Fit = Callable[[list[LabelledAssembly], int], Scorer]
"""`fit(training assemblies, round)`: the round's model as a scorer."""
Labeller = Callable[[Scorer, Assembly], LabelledAssembly | None]
"""`label(scorer, assembly)`: the assembly with its training targets, or None (no label)."""
Score = Callable[[Scorer], dict]
"""`score(scorer)`: the test figures per size (`size_figures`)."""


def search_labeller(
    search: VerifiedSearch, simulator: Any, mask: bool = True, probe_checks: int | None = None
) -> Labeller:
    """Labels from the verified search's checked plan (grace/planning/self_labels.py); with
    `mask`, only the parts whose label the search knows carry a loss; with `probe_checks`,
    the steps out of the orders' states that the search left unknown are decided by a
    sub-search of at most that many checks each (`probe_steps`)."""

    def label(scorer: Scorer, assembly: Assembly) -> LabelledAssembly | None:
        steps = SimulatorSteps(simulator, assembly)
        result, plan = search.checked(scorer, assembly, steps)
        prior = FixationPrior.of_steps(steps)
        negatives = search_negatives(result, prior)
        orders = verified_orders(plan)
        probed = None
        if probe_checks is not None and orders:
            probed = probe_steps(orders, negatives, steps, prior, probe_checks)
        return plan_labels(plan, assembly, negatives if mask else None, probed)

    return label


def brute_force_labeller(simulator: Any) -> Labeller:
    """The simulator's ground truth of the same assembly: the upper bound."""

    def label(scorer: Scorer, assembly: Assembly) -> LabelledAssembly:
        sample = simulator.label(assembly)
        sample.info["labels"] = Labels.brute_force.value
        return sample

    return label


def label_round(
    scorer: Scorer, drawn: Sequence[Assembly], label: Labeller, figures: RoundFigures
) -> list[LabelledAssembly]:
    """The drawn assemblies that got a label, counted into `figures`."""
    out, known = [], []
    for assembly in drawn:
        sample = label(scorer, assembly)
        figures.drawn += 1
        if sample is None:
            figures.not_found += 1
            continue
        out.append(sample)
        figures.labelled += 1
        if sample.truth.feasible:
            figures.verified += 1
            figures.orders += int(sample.info.get("verified_orders", 0))
            if "known_share" in sample.info:
                known.append(sample.info["known_share"])
        else:
            figures.infeasible += 1
    figures.known_share = sum(known) / len(known) if known else None
    return out


def expert_iteration(
    rounds: int,
    train: list[LabelledAssembly],
    draw: Callable[[int], list[Assembly]],
    fit: Fit,
    label: Labeller,
    score: Score,
    report: Callable[[list[RoundFigures]], None],
) -> list[RoundFigures]:
    """Rounds 0..`rounds` (module docstring): `draw(r)` gives round r's new assemblies, each
    round's model trains on `train` plus every assembly labelled so far; `report` gets the
    figures after every round."""
    added: list[LabelledAssembly] = []
    scorer: Scorer | None = None
    done: list[RoundFigures] = []
    for r in range(rounds + 1):
        figures = RoundFigures(round=r)
        tick = time.perf_counter()
        if scorer is not None:
            drawn = draw(r)
            figures.seconds["draw"] = time.perf_counter() - tick
            tick = time.perf_counter()
            added += label_round(scorer, drawn, label, figures)
            figures.seconds["label"] = time.perf_counter() - tick
            tick = time.perf_counter()
        figures.added = len(added)
        scorer = fit([*train, *added], r)
        figures.seconds["train"] = time.perf_counter() - tick
        tick = time.perf_counter()
        figures.test = score(scorer)
        figures.seconds["test"] = time.perf_counter() - tick
        done.append(figures)
        report(done)
        log.info(
            "round %d: %d added, %d of %d drawn verified, %.0f s", r, figures.added,
            figures.verified, figures.drawn, sum(figures.seconds.values()),
        )  # fmt: skip
    return done
