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
from grace.evaluation.self_train import Labels, RoundFigures, chosen_round
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.fixation_prior import FixationPrior
from grace.planning.search import VerifiedSearch
from grace.planning.self_labels import (
    own_sequence,
    plan_labels,
    probe_steps,
    search_negatives,
    verified_orders,
)
from grace.planning.sequences import Scorer
from grace.planning.step_checks import accepted_throughout
from grace.planning.thresholds import AbsoluteThreshold

log = logging.getLogger(__name__)


Fit = Callable[[list[LabelledAssembly], int], Scorer]
"""`fit(training assemblies, round)`: the round's model as a scorer."""
Labeller = Callable[[Scorer, Assembly], LabelledAssembly | None]
"""`label(scorer, assembly)`: the assembly with its training targets, or None (no label)."""
Score = Callable[[Scorer], dict]
"""`score(scorer)`: the test figures per size (`size_figures`)."""
Rule = Callable[[Scorer], Scorer]
"""A planning rule (`threshold=`, grace/planning/thresholds.py): the scores Algorithm 1 plans
(the paper's, `AbsoluteThreshold`, plans the policy's scores as they are)."""
PAPER_RULE: Rule = AbsoluteThreshold()
"""The labellers' default rule: the paper's λ."""
FIRST_CHOICE = "first_choice_verified"
"""`info` key of a feasible label: whether the labelling policy's first choice (`own_sequence`,
the sequence P@1 judges) passed the simulator's check at every step."""


def search_labeller(
    search: VerifiedSearch,
    simulator: Any,
    mask: bool = True,
    probe_checks: int | None = None,
    threshold: float = 0.5,
    probe_own_sequence: bool = False,
    rule: Rule = PAPER_RULE,
) -> Labeller:
    """Labels from the verified search's checked plan (grace/planning/self_labels.py); with
    `mask`, only the parts whose label the search knows carry a loss; with `probe_checks`,
    the steps out of the orders' states that the search left unknown are decided by a
    sub-search of at most that many checks each (`probe_steps`), and with
    `probe_own_sequence` so are those out of the states on the policy's own first choice at λ
    = `threshold` (`own_sequence`, planned under `rule`; the search orders its steps by the
    policy's own scores, as `task=plan` does). A label with a verified order records whether
    that first choice is one (`FIRST_CHOICE`)."""

    def label(scorer: Scorer, assembly: Assembly) -> LabelledAssembly | None:
        steps = SimulatorSteps(simulator, assembly)
        result, plan = search.checked(scorer, assembly, steps)
        prior = FixationPrior.of_steps(steps)
        negatives = search_negatives(result, prior)
        orders = verified_orders(plan)
        if not orders:
            return plan_labels(plan, assembly, negatives if mask else None)
        first = own_sequence(rule(scorer), assembly, threshold)
        probed = None
        if probe_checks is not None:
            paths = [first] if probe_own_sequence else []
            probed = probe_steps(orders, negatives, steps, prior, probe_checks, paths)
        sample = plan_labels(plan, assembly, negatives if mask else None, probed)
        sample.info[FIRST_CHOICE] = accepted_throughout(first, steps)
        return sample

    return label


def brute_force_labeller(
    simulator: Any, threshold: float = 0.5, rule: Rule = PAPER_RULE
) -> Labeller:
    """The simulator's ground truth of the same assembly: the upper bound. A feasible one
    records whether the policy's first choice at λ = `threshold` (planned under `rule`) is one
    of its orders (`FIRST_CHOICE`)."""

    def label(scorer: Scorer, assembly: Assembly) -> LabelledAssembly:
        sample = simulator.label(assembly)
        sample.info["labels"] = Labels.brute_force.value
        if sample.truth.feasible:
            first = own_sequence(rule(scorer), assembly, threshold)
            sample.info[FIRST_CHOICE] = sample.truth.is_order(first)
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


def first_choice_share(samples: Sequence[LabelledAssembly]) -> float | None:
    """Of the feasible `samples` (as their labels know), the share whose labelling policy's
    first choice the simulator accepted at every step (`FIRST_CHOICE`): strict P@1 of that
    policy on them, read from the simulator instead of a ground truth."""
    right = [s.info[FIRST_CHOICE] for s in samples if FIRST_CHOICE in s.info]
    return sum(right) / len(right) if right else None


def expert_iteration(
    rounds: int,
    train: list[LabelledAssembly],
    draw: Callable[[int], list[Assembly]],
    fit: Fit,
    label: Labeller,
    score: Score,
    report: Callable[[list[RoundFigures]], None],
    patience: int | None = None,
) -> list[RoundFigures]:
    """Rounds 0..`rounds` (module docstring): `draw(r)` gives round r's new assemblies, each
    round's model trains on `train` plus every assembly labelled so far; `report` gets the
    figures after every round. Each round's model is judged on the next round's draws
    (`RoundFigures.first_choice`); with `rounds` ≥ 1 the last one on one more draw (round
    `rounds` + 1), labelled for that only. With `patience` p, the rounds stop early once the
    last p judged rounds were none better than an earlier one (`chosen_round`): round r's
    draws then only judged round r − 1, and no model trains on them."""
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
            labelled = label_round(scorer, drawn, label, figures)
            done[-1].first_choice = first_choice_share(labelled)
            if _stale(done, patience):
                judge = figures.seconds["draw"] + time.perf_counter() - tick
                done[-1].seconds["judge"] = judge
                report(done)
                log.info(
                    "stopped before round %d: no better first choice for %d rounds", r, patience
                )
                return done
            added += labelled
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
    if rounds and scorer is not None:
        tick = time.perf_counter()
        judged = label_round(scorer, draw(rounds + 1), label, RoundFigures(round=rounds + 1))
        done[-1].first_choice = first_choice_share(judged)
        done[-1].seconds["judge"] = time.perf_counter() - tick
        report(done)
    return done


def _stale(done: Sequence[RoundFigures], patience: int | None) -> bool:
    """Whether the last `patience` judged rounds were none better than an earlier round."""
    best = chosen_round([r.first_choice for r in done])
    return patience is not None and best is not None and len(done) - 1 - best >= patience
