"""Verified search: the policy orders the steps, the simulator checks each before it is taken.

Algorithm 1 (paper, Sec. IV-C.3) trusts the network's scores; when the network is wrong the user
gets orders the robot cannot execute. Here the policy only decides in which order candidate
steps are *tried*: a step is taken only after a simulator step check (grace/planning/
step_checks.py) accepts it, so every returned order is executable by construction, and a
wrong score costs checks, not correctness (docs/planning.md).

The search runs over states (sets of placed parts), not prefixes: each state is scored at most
once and each (state, part) checked at most once. It runs in one of two directions:

- `backward` (assembly by disassembly): from the complete assembly, it takes away a part that
  can be placed last, i.e. the check of placing it into the rest accepts it, down to the empty
  state; the order is the removals reversed. Obstacles only accumulate as parts are placed, so
  a part blocked with everything around it gets free as the others are taken away: going
  backward, a step refused now may pass later, and dead ends are rare;
- `forward` (assembly): from the empty state, it places a part the check accepts, up to the
  complete assembly. A part placed too early can leave another one blocked for good, which the
  search learns only when it tries that one, deeper down.

A state is *dead* when no verified path leads from it to the goal (every step out of it is
refused or leads to a dead state), *alive* when one does. A refused step whose part is blocked by
placed parts (`StepCheck.conflicts`) teaches a block (`learn_blocks`): the part cannot be placed
in any state holding those parts. The search then skips every later step that places it in such
a state without a check, and, forward, drops every state holding the parts without the part
(no order completes from there); it takes the parts placed earliest, so that the search jumps
back as far as possible. The search stops when `k` verified orders exist (the `k` most probable
of them are returned), when the start is dead (the assembly is infeasible: every order was
refuted, by the search or, before it, by the orders every order must keep, `precedence`:
grace/planning/precedence.py), or when its budget of checks or seconds runs out ("not found
within budget"). Which unchecked step comes next is the frontier's choice:

- `greedy`: depth first; in the deepest open state, its best-scored unchecked step. With a good
  policy this walks straight to the goal (N checks for N parts) and backtracks only where a
  refusal or a dead end forces it;
- `best_first`: the unchecked step with the most probable verified prefix (the product of the
  step scores), Dijkstra over −log p: wider, it finds more probable orders first.

A step's score is the policy's score of placing the part in the state before it (backward: the
rest), so an order's probability is the product of its steps' scores in both directions.
"""

from __future__ import annotations

import heapq
import logging
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from enum import StrEnum

import numpy as np

from grace.domain.assembly import Assembly, full_mask, mask_to_parts
from grace.domain.orders import GroundTruth
from grace.planning.cell_steps import SimulatorSteps
from grace.planning.fixation_prior import FixationPrior
from grace.planning.plans import Plan, search_plan, search_steps
from grace.planning.precedence import refuted
from grace.planning.sequences import Scorer
from grace.planning.step_checks import BlockerSteps, StepOracle, blocking_set, brute_force
from grace.planning.topk import FULL_TABLE_MAX_PARTS, Ranked, StateScores, lazy_scores

log = logging.getLogger(__name__)

RECORDED_EVENTS = 2000
"""Search events a plan keeps with their reasons (plan.rrd draws them; plan.json counts the
refusals among them)."""

Refutation = Callable[[], int | None]
"""`refute()`: a part no order can place, proved without a search (grace/planning/
precedence.py), or None."""

StepPrior = Callable[[int, int], bool]
"""`prior(before, part)`: whether the step placing `part` into the state `before` is worth
trying first (grace/planning/fixation_prior.py)."""


class Direction(StrEnum):
    """Which way the search walks the state DAG (module docstring)."""

    backward = "backward"
    forward = "forward"


class Frontier(StrEnum):
    """Which unchecked step the search tries next (module docstring)."""

    greedy = "greedy"
    best_first = "best_first"


class Outcome(StrEnum):
    """How a search ended."""

    verified = "verified"  # at least one verified order
    infeasible = "infeasible"  # every order refuted: the space is exhausted
    budget = "not found within budget"  # checks or seconds ran out first


@dataclass(frozen=True)
class SearchEvent:
    """One step of the search, for recordings: `kind` is "placed" (the check accepted `part` in
    `state`), "refused" (it refused it; `blocked_by`: placed parts that keep it out for good,
    None if fixation refused it) or "ruled_out" (`state` is dead without a check of its own:
    `part` can no longer be placed once `blocked_by` is)."""

    kind: str
    state: int
    part: int
    checks: int
    blocked_by: int | None = None


@dataclass(eq=False)
class SearchResult:
    """What one search found and what it cost.

    `orders`: the verified orders found, the most probable first (at most k); `checks`: the
    distinct step checks asked; `first_checks` / `first_seconds`: spent when the first verified
    order was complete (None without one); `seconds`: the whole search's wall time (scoring,
    checks and the cell queries they trigger); `expanded`: states scored (forward passes);
    `verified`: the verified part of the state DAG (`placeable`: steps the checks accepted,
    `completable`: those on verified orders); `exhausted`: the search ran out of steps to try,
    so `verified` holds every order; `unplaceable`: the part that the orders every order must
    keep leave without a usable option (grace/planning/precedence.py), when that proved the
    assembly infeasible before any step check.
    """

    outcome: Outcome
    orders: list[Ranked]
    checks: int
    seconds: float
    first_checks: int | None
    first_seconds: float | None
    expanded: int
    verified: GroundTruth
    exhausted: bool
    events: list[SearchEvent] = field(default_factory=list)
    unplaceable: int | None = None


class _Node:
    """One scored state: its steps in the order they will be tried and what is known of it."""

    __slots__ = ("alive", "dead", "logp", "open", "order", "parents", "pos", "row", "state", "via")

    def __init__(
        self, state: int, row: np.ndarray, candidates: list[int], allowed: list[bool], logp: float
    ) -> None:
        self.state = state
        self.row = row
        # the steps the prior allows first, each group best-scored first
        self.order = sorted(candidates, key=lambda p: (not allowed[p], -row[p]))
        self.pos = 0
        self.open = len(self.order)  # steps not yet known to lead nowhere
        self.parents: list[tuple[int, int]] = []  # verified steps into this state
        self.via: tuple[int, int] | None = None  # the step the search first reached it by
        self.alive = False
        self.dead = False
        self.logp = logp


def _log(score: float) -> float:
    return math.log(score) if score > 0 else -math.inf


def removal_scores(scorer: Scorer, assembly: Assembly) -> StateScores:
    """Backward step scores: for each part p of a state S, the policy's score of placing p in
    S without p (one batched call per state, each state at most once)."""
    cache: dict[int, np.ndarray] = {}

    def scores(state: int) -> np.ndarray:
        if state not in cache:
            parts = mask_to_parts(state)
            rests = np.array([state & ~(1 << p) for p in parts], dtype=np.int64)
            row = np.zeros(assembly.n_parts)
            if parts:
                table = np.asarray(scorer(assembly, rests), dtype=np.float64)
                row[parts] = table[np.arange(len(parts)), parts]
            cache[state] = row
        return cache[state]

    return scores


@dataclass(frozen=True)
class VerifiedSearch:
    """`planner=verified` (grace/conf/planner/verified.yaml): the search's settings.

    `k`: verified orders wanted (None: all of them, the exhaustive mode); `max_checks` /
    `max_seconds`: the budget (None: unlimited). Each (state, part) is checked at most once,
    so forward the checks never exceed the brute force's (the reachable states' pairs);
    backward they may, as states no order reaches can be asked about. `precedence`: refute
    first by the orders every order keeps (grace/planning/precedence.py); `exhaustive_parts`
    / `exhaustive_after`: up to that many parts, after that many checks per part, the brute
    force decides whether any order exists (`search`)."""

    k: int | None = 1
    direction: Direction = Direction.backward
    frontier: Frontier = Frontier.greedy
    learn_blocks: bool = True
    fixation_prior: bool = True
    precedence: bool = True
    exhaustive_parts: int = 20
    exhaustive_after: int = 3
    touch_tolerance: float = 0.5
    max_checks: int | None = None
    max_seconds: float | None = None

    def search(
        self,
        scores: StateScores,
        oracle: StepOracle,
        prior: StepPrior | None = None,
        refute: Refutation | None = None,
        exhaust: Callable[[], GroundTruth] | None = None,
        prior_proves: bool = False,
        start: int = 0,
    ) -> SearchResult:
        """Search one assembly: `scores(state)` gives the policy's score of each step out of
        `state` in this search's direction, `oracle` the simulator's step checks; the steps
        `prior(before, part)` allows are tried first, and the others never if `prior_proves`
        (the prior is exact: a step it refuses is on no order); `refute()`, asked first, may
        prove the assembly infeasible without a step check; `exhaust()`, the brute force on the same
        checks, decides feasibility once the search has spent `exhaustive_after` × N checks
        on an assembly of at most `exhaustive_parts` parts without a verdict: a proof then
        costs at most the brute force's on top (its checks are added to the search's).
        `start` (forward only): the parts already placed, so the search completes that state
        (its orders list the parts placed after it; `refute` and `exhaust`, which speak of the
        whole assembly, must then be None)."""
        if start and (self.direction != Direction.forward or refute or exhaust):
            raise ValueError("a search from a placed state runs forward, without refute/exhaust")
        if start == full_mask(oracle.n_parts):
            raise ValueError("a search from the complete assembly has nothing left to place")
        return _Search(self, scores, oracle, prior, refute, exhaust, prior_proves, start).run()

    def plan(self, scorer: Scorer, assembly: Assembly, oracle: StepOracle) -> SearchResult:
        """Search `assembly` with the policy `scorer` (its states scored lazily, forward one
        forward pass per state, backward one batched call per state), with the fixation prior
        (grace/planning/fixation_prior.py) if `fixation_prior`: read off the checks' own rule
        when `oracle` exposes it (then the steps it refuses are dropped), else off the
        geometry (then they are tried last)."""
        refute = exhaust = None
        if isinstance(oracle, BlockerSteps):
            fixation, proves = FixationPrior.of_steps(oracle), True
            if self.precedence:
                refute = lambda: refuted(oracle, fixation)  # noqa: E731
            exhaust = lambda: brute_force(oracle)  # noqa: E731
        else:
            fixation, proves = FixationPrior.of(assembly, self.touch_tolerance), False
        prior = fixation.allows if self.fixation_prior else None
        scores = lazy_scores if self.direction == Direction.forward else removal_scores
        return self.search(scores(scorer, assembly), oracle, prior, refute, exhaust, proves)

    def checked_plan(
        self,
        scorer: Scorer,
        assembly: Assembly,
        steps: SimulatorSteps,
        truth: GroundTruth | None = None,
    ) -> Plan:
        """Search `assembly` (`plan`) with `steps`' simulator checks; the plan lists the verified
        orders and the first `RECORDED_EVENTS` events, each refusal with its reason."""
        return self.checked(scorer, assembly, steps, truth)[1]

    def checked(
        self,
        scorer: Scorer,
        assembly: Assembly,
        steps: SimulatorSteps,
        truth: GroundTruth | None = None,
    ) -> tuple[SearchResult, Plan]:
        """`checked_plan` with the search's whole result (every event, where the plan keeps the
        first `RECORDED_EVENTS`): self-training reads all its refusals."""
        budget = self.max_checks is not None or self.max_seconds is not None
        if assembly.n_parts > FULL_TABLE_MAX_PARTS and not budget:
            log.warning(
                "%d parts and no budget: the search may run long before it proves the assembly "
                "infeasible; set planner.max_seconds or planner.max_checks",
                assembly.n_parts,
            )
        result = self.plan(scorer, assembly, steps)
        start = time.perf_counter()
        events = search_steps(result, steps.checker, RECORDED_EVENTS)
        settings = {"name": "verified", **asdict(self)}  # StrEnum values serialise as names
        plan = search_plan(result, steps.checker, truth, settings, 0.0, events)
        return result, replace(
            plan, search=replace(plan.search, record_seconds=time.perf_counter() - start)
        )


class _Search:
    """The state of one search (see the module docstring)."""

    def __init__(
        self,
        config: VerifiedSearch,
        scores: StateScores,
        oracle: StepOracle,
        prior: StepPrior | None,
        refute: Refutation | None = None,
        exhaust: Callable[[], GroundTruth] | None = None,
        prior_proves: bool = False,
        start: int = 0,
    ) -> None:
        self.config = config
        self.prior = prior
        self.prior_proves = prior_proves
        self.refute = refute
        small = oracle.n_parts <= config.exhaustive_parts
        self.exhaust = exhaust if config.k is not None and small else None
        self.extra_checks = 0  # the brute force's, once it ran
        self.forward = config.direction == Direction.forward
        self.scores = scores
        self.oracle = oracle
        self.n = oracle.n_parts
        self.full = full_mask(self.n)
        self.start_state, goal = (start, self.full) if self.forward else (self.full, 0)
        self.nodes: dict[int, _Node] = {}
        self.heap: list[tuple[float, float, int, int]] = []
        self.pushes = 0
        self.states = np.zeros(64, dtype=np.int64)  # expanded states, in expansion order
        self.blocks = np.zeros((16, 2), dtype=np.int64)  # learnt (blocking parts, part bit)
        self.n_blocks = 0
        self.accepted: dict[int, int] = {}  # per state, the steps the checks accepted there
        self.goal = _Node(goal, np.zeros(self.n), [], [], 0.0)
        self.goal.alive = True
        self.events: list[SearchEvent] = []
        self.first: tuple[int, float] | None = None
        self.n_orders = 0

    def _exhausted_by_brute_force(self, root: _Node) -> bool:
        """Past its share of checks, the brute force decides: True if it refuted every order
        (the root is then dead); a feasible verdict leaves the search to find the order."""
        if self.exhaust is None or self.oracle.checks < self.config.exhaustive_after * self.n:
            return False
        truth, self.exhaust = self.exhaust(), None
        self.extra_checks = truth.checks
        if not truth.feasible:
            self._kill(root)
        return not truth.feasible

    # Directions ------------------------------------------------------------------------------

    def _before(self, state: int, part: int) -> int:
        """The state a step out of `state` places `part` into (what its check asks about)."""
        return state if self.forward else state & ~(1 << part)

    def _after(self, state: int, part: int) -> int:
        return state | 1 << part if self.forward else state & ~(1 << part)

    @property
    def _origin(self) -> int:
        """The state the orders start from, forward (the empty one unless parts were placed
        before the search)."""
        return self.start_state if self.forward else 0

    def _depth(self, state: int) -> int:
        """Steps from the start."""
        return state.bit_count() if self.forward else self.n - state.bit_count()

    # The frontier ----------------------------------------------------------------------------

    def _push(self, node: _Node) -> None:
        """Queue the node's next untried step (each node has at most one entry in the heap)."""
        if node.pos >= len(node.order):
            return
        score = float(node.row[node.order[node.pos]])
        depth = self._depth(node.state)
        if self.config.frontier == Frontier.greedy:
            key = (-depth, -score)
        else:
            key = (-(node.logp + _log(score)), -depth)
        self.pushes += 1
        heapq.heappush(self.heap, (*key, self.pushes, node.state))

    def _expand(self, state: int, logp: float) -> _Node:
        row = np.asarray(self.scores(state), dtype=np.float64)
        candidates = mask_to_parts(self.full & ~state if self.forward else state)
        allowed = [True] * self.n
        if self.prior is not None:
            for part in candidates:
                allowed[part] = self.prior(self._before(state, part), part)
            if self.prior_proves:  # the others lead nowhere
                candidates = [p for p in candidates if allowed[p]]
        node = _Node(state, row, candidates, allowed, logp)
        node.dead = not candidates
        self.nodes[state] = node
        count = len(self.nodes)
        if count > len(self.states):
            self.states = np.concatenate([self.states, np.zeros_like(self.states)])
        self.states[count - 1] = state
        self._push(node)
        return node

    def _placement_order(self, node: _Node, before: int, conflicts: tuple[int, ...]) -> list[int]:
        """The parts of the state `before` a refused step was checked in, earliest first:
        forward, in the order the search placed them; backward (where none was placed yet),
        those meeting the most conflicts first, which keeps the blocking set small."""
        if not self.forward:
            return sorted(mask_to_parts(before), key=lambda q: -sum(c >> q & 1 for c in conflicts))
        parts = []
        while node.via is not None:
            state, part = node.via
            parts.append(part)
            node = self.nodes[state]
        return [*mask_to_parts(self.start_state), *parts[::-1]]

    # What is known ---------------------------------------------------------------------------

    def _learnt(self, state: int, part: int | None = None) -> tuple[int, int] | None:
        """The first learnt block whose blocking parts `state` holds, for `part` (a step placing
        it into `state`) or, with `part` None, for any part `state` lacks (forward: no order
        completes from `state`), as (blocking parts, part); None if there is none."""
        blocks = self.blocks[: self.n_blocks]
        hit = (state & blocks[:, 0]) == blocks[:, 0]
        hit &= (state & blocks[:, 1]) == 0 if part is None else blocks[:, 1] == 1 << part
        found = np.flatnonzero(hit)
        if not found.size:
            return None
        blocking, bit = blocks[found[0]].tolist()
        return blocking, bit.bit_length() - 1

    def _step_dead(self, node: _Node) -> None:
        """One more step out of `node` leads nowhere; a node without open steps is dead."""
        stack = [node]
        while stack:
            current = stack.pop()
            current.open -= 1
            if current.open <= 0 and not current.alive and not current.dead:
                current.dead = True
                stack.extend(self.nodes[s] for s, _ in current.parents)

    def _kill(self, node: _Node) -> None:
        if node.dead or node.alive:
            return
        node.dead = True
        for state, _ in node.parents:
            self._step_dead(self.nodes[state])

    def _learn(self, blocking: int, part: int, node: _Node) -> None:
        """`part` is blocked for good once `blocking` is placed. Forward, every expanded state
        holding `blocking` but not `part` is dead (`node`, where the refusal came, among them)."""
        bit = 1 << part
        if self.n_blocks == len(self.blocks):
            self.blocks = np.concatenate([self.blocks, np.zeros_like(self.blocks)])
        self.blocks[self.n_blocks] = (blocking, bit)
        self.n_blocks += 1
        if not blocking:  # no option of the part is ever usable: no order exists
            self._kill(self.nodes[self.start_state])
        if not self.forward:
            self._step_dead(node)
            return
        states = self.states[: len(self.nodes)]
        hit = ((states & blocking) == blocking) & ((states & bit) == 0)
        for state in states[hit].tolist():
            other = self.nodes[state]
            if not other.dead and not other.alive and other is not node:
                self.events.append(
                    SearchEvent("ruled_out", state, part, self.oracle.checks, blocking)
                )
            self._kill(other)
        if not node.dead:  # a verified order went on from here: the world is not monotone
            self._step_dead(node)

    def _revive(self, node: _Node) -> None:
        """A verified path now leads from `node` to the goal; so it does from its ancestors."""
        stack = [node]
        while stack:
            current = stack.pop()
            if current.alive:
                continue
            current.alive = True
            stack.extend(self.nodes[s] for s, _ in current.parents)

    def _count_orders(self) -> int:
        """Verified orders: paths from the start to the goal through alive states."""
        alive = sorted(
            (n for n in self.nodes.values() if n.alive and n.state != self.start_state),
            key=lambda n: self._depth(n.state),
        )
        paths = {self.start_state: 1}
        for node in [*alive, self.goal]:
            paths[node.state] = sum(paths.get(s, 0) for s, _ in node.parents)
        return paths[self.goal.state]

    # The loop --------------------------------------------------------------------------------

    def _enough(self) -> bool:
        k = self.config.k
        return k is not None and self.n_orders >= k

    def _out_of_budget(self, start: float) -> bool:
        cfg = self.config
        if cfg.max_checks is not None and self.oracle.checks >= cfg.max_checks:
            return True
        return cfg.max_seconds is not None and time.perf_counter() - start >= cfg.max_seconds

    def _take(self, node: _Node, part: int, start: float) -> None:
        """The check accepted the step placing `part` out of `node`'s state: follow it."""
        before, child_state = self._before(node.state, part), self._after(node.state, part)
        self.accepted[before] = self.accepted.get(before, 0) | 1 << part
        self.events.append(SearchEvent("placed", before, part, self.oracle.checks))
        if child_state == self.goal.state:
            child = self.goal
        else:
            child = self.nodes.get(child_state)
            if child is None:
                block = None
                if self.forward and self.config.learn_blocks:
                    block = self._learnt(child_state)
                if block is not None:
                    blocking, blocked = block
                    self.events.append(
                        SearchEvent("ruled_out", child_state, blocked, self.oracle.checks, blocking)
                    )
                    self._step_dead(node)
                    return
                logp = node.logp + _log(float(node.row[part]))
                child = self._expand(child_state, logp)
        child.parents.append((node.state, part))
        if child.via is None:
            child.via = (node.state, part)
        if child.dead:
            self._step_dead(node)
        elif child.alive:
            if self.first is None:
                self.first = (self.oracle.checks, time.perf_counter() - start)
            self._revive(node)
            self.n_orders = 1 if self.config.k == 1 else self._count_orders()

    def _refuse(self, node: _Node, part: int, conflicts: tuple[int, ...] | None) -> None:
        """The check refused the step placing `part` out of `node`'s state."""
        before = self._before(node.state, part)
        blocking = None
        if conflicts is not None:
            blocking = blocking_set(conflicts, self._placement_order(node, before, conflicts))
        self.events.append(SearchEvent("refused", before, part, self.oracle.checks, blocking))
        if self.config.learn_blocks and blocking is not None:
            self._learn(blocking, part, node)
        else:
            self._step_dead(node)

    def run(self) -> SearchResult:
        start = time.perf_counter()
        unplaceable = self.refute() if self.refute is not None else None
        if unplaceable is not None:
            # proved infeasible without a step check, and without scoring a state
            root = self.nodes[self.start_state] = _Node(
                self.start_state, np.zeros(self.n), [], [], 0
            )
            root.dead = True
        else:
            root = self._expand(self.start_state, 0.0)
        out_of_budget = False
        while self.heap and not root.dead and not self._enough():
            if self._exhausted_by_brute_force(root):
                break
            *_, state = heapq.heappop(self.heap)
            node = self.nodes[state]
            if node.dead:
                continue
            part = node.order[node.pos]
            before = self._before(state, part)
            known = self._learnt(before, part) if self.config.learn_blocks else None
            if known is None and self._out_of_budget(start):
                out_of_budget = True
                break
            node.pos += 1
            self._push(node)
            if known is not None:  # refused for good: no need to ask
                self.events.append(
                    SearchEvent("ruled_out", before, part, self.oracle.checks, known[0])
                )
                self._step_dead(node)
                continue
            verdict = self.oracle.check(before, part)
            if verdict.feasible:
                self._take(node, part, start)
            else:
                self._refuse(node, part, verdict.conflicts)
        seconds = time.perf_counter() - start
        exhausted = not out_of_budget and not self._enough()
        if self.goal.parents and root.alive:
            outcome = Outcome.verified
        elif exhausted:
            outcome = Outcome.infeasible
        else:
            outcome = Outcome.budget
        first_checks, first_seconds = self.first if self.first else (None, None)
        return SearchResult(
            outcome=outcome,
            orders=self._best_orders(),
            checks=self.oracle.checks + self.extra_checks,
            seconds=seconds,
            first_checks=first_checks,
            first_seconds=first_seconds,
            expanded=len(self.nodes),
            verified=self._verified(),
            exhausted=exhausted,
            events=self.events,
            unplaceable=unplaceable,
        )

    # Results ---------------------------------------------------------------------------------

    def _order_steps(self) -> dict[int, dict[int, float]]:
        """The steps on verified orders as (state before, part) → the step's score."""
        steps: dict[int, dict[int, float]] = {}
        for node in [*self.nodes.values(), self.goal]:
            if not node.alive:
                continue
            for state, part in node.parents:
                before = self._before(state, part)
                steps.setdefault(before, {})[part] = float(self.nodes[state].row[part])
        return steps

    def _best_orders(self) -> list[Ranked]:
        """The k most probable verified orders: A* over the verified steps, with the exact
        best completion of each state as the bound (every verified step completes)."""
        steps, start = self._order_steps(), self._origin
        if start not in steps:
            return []
        rest = {self.full: 0.0}  # best log-probability still to come
        for state in sorted(steps, key=int.bit_count, reverse=True):
            rest[state] = max(
                _log(score) + rest[state | 1 << part] for part, score in steps[state].items()
            )
        heap: list[tuple[float, int, tuple[int, ...], float]] = [(-rest[start], 0, (), 0.0)]
        out: list[Ranked] = []
        pushes = 0
        while heap and (self.config.k is None or len(out) < self.config.k):
            _, _, prefix, logp = heapq.heappop(heap)
            state = start | sum(1 << p for p in prefix)
            if state == self.full:
                probs = tuple(steps[s][p] for s, p in _prefix_steps(prefix, start))
                out.append(Ranked(prefix, float(np.prod(probs)), probs))
                continue
            for part, score in steps[state].items():
                step = logp + _log(score)
                pushes += 1
                key = -(step + rest[state | 1 << part])
                heapq.heappush(heap, (key, pushes, (*prefix, part), step))
        return out

    def _verified(self) -> GroundTruth:
        """The verified part of the state DAG, forward: the steps the checks accepted, and
        those on verified orders."""
        completable: dict[int, int] = {}
        for before, parts in self._order_steps().items():
            completable[before] = sum(1 << p for p in parts)
        reached = {b | 1 << p for b, parts in self.accepted.items() for p in mask_to_parts(parts)}
        states = sorted({self._origin, *self.accepted, *reached})
        return GroundTruth(
            n_parts=self.n,
            states=np.array(states, dtype=np.int64),
            placeable=np.array([self.accepted.get(s, 0) for s in states], dtype=np.int64),
            completable=np.array([completable.get(s, 0) for s in states], dtype=np.int64),
        )


def _prefix_steps(order: tuple[int, ...], start: int = 0) -> list[tuple[int, int]]:
    """(state before, part) of each step of `order`, placed after the parts of `start`."""
    out, state = [], start
    for part in order:
        out.append((state, part))
        state |= 1 << part
    return out
