"""Verified search: the policy orders the steps, the simulator checks each before it is taken.

Algorithm 1 (paper, Sec. IV-C.3) trusts the network's scores; when the network is wrong the user
gets orders the robot cannot execute. Here the network only decides in which order candidate
steps are *tried*: a step is taken only after a simulator step check (grace/planning/
step_checks.py) accepts it, so every returned order is executable by construction, and a
wrong score costs checks, not correctness (docs/planning.md).

The search runs over states (sets of placed parts), not prefixes: each state is scored at most
once (one forward pass, `StateScores`) and each (state, part) checked at most once. A state is
*dead* when no order completes from it: every step out of it is refused or leads to a dead
state, or a refusal says a part left to place is blocked by placed parts for good
(`StepCheck.blocked_by`): then every state holding those parts but not that part is dead too,
checked or not, and the search drops them (`learn_blocks`). A state is *alive* when a verified
path leads from it to the complete assembly. The search stops when `k` verified orders exist
(the `k` most probable of them are returned), when the empty state is dead (the assembly is
infeasible: every order was refuted), or when its budget of checks or seconds runs out
("not found within budget"). Which unchecked step comes next is the frontier's choice:

- `greedy`: depth first; in the deepest open state, its best-scored unchecked step. With a good
  policy this walks straight to the goal (N checks for N parts) and backtracks only where a
  refusal or a dead end forces it;
- `best_first`: the unchecked step with the most probable verified prefix (the product of the
  step scores), Dijkstra over −log p: wider, it finds more probable orders first.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from grace.domain.assembly import full_mask
from grace.domain.orders import GroundTruth
from grace.planning.step_checks import StepOracle
from grace.planning.topk import Ranked, StateScores


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
    `state`), "refused" (it refused it; `blocked_by` as in `StepCheck`) or "ruled_out" (`state`
    is dead without a check of its own: `part` can no longer be placed once `blocked_by` is)."""

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
    so `verified` holds every order.
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


class _Node:
    """One scored state: its steps in the order they will be tried and what is known of it."""

    __slots__ = ("alive", "dead", "logp", "open", "order", "parents", "pos", "row", "state")

    def __init__(self, state: int, row: np.ndarray, n_parts: int, logp: float) -> None:
        self.state = state
        self.row = row
        todo = np.flatnonzero((state >> np.arange(n_parts) & 1) == 0)
        self.order = todo[np.argsort(-row[todo], kind="stable")].tolist()
        self.pos = 0
        self.open = len(self.order)  # steps not yet known to lead nowhere
        self.parents: list[tuple[int, int]] = []  # verified steps into this state
        self.alive = False
        self.dead = False
        self.logp = logp


def _log(score: float) -> float:
    return math.log(score) if score > 0 else -math.inf


@dataclass(frozen=True)
class VerifiedSearch:
    """`planner=verified` (grace/conf/planner/verified.yaml): the search's settings.

    `k`: verified orders wanted (None: all of them, the exhaustive mode); `max_checks` /
    `max_seconds`: the budget (None: unlimited; the check count never exceeds the brute
    force's, since each (state, part) is checked at most once)."""

    k: int | None = 1
    frontier: Frontier = Frontier.greedy
    learn_blocks: bool = True
    max_checks: int | None = None
    max_seconds: float | None = None

    verify = True  # the task layer lists these orders as verified (the top-k listing does not)

    def search(self, scores: StateScores, oracle: StepOracle) -> SearchResult:
        """Search one assembly: `scores(state)` gives the policy's part scores, `oracle` the
        simulator's step checks."""
        return _Search(self, scores, oracle).run()


class _Search:
    """The state of one search (see the module docstring)."""

    def __init__(self, config: VerifiedSearch, scores: StateScores, oracle: StepOracle) -> None:
        self.config = config
        self.scores = scores
        self.oracle = oracle
        self.n = oracle.n_parts
        self.full = full_mask(self.n)
        self.nodes: dict[int, _Node] = {}
        self.heap: list[tuple[float, float, int, int]] = []
        self.pushes = 0
        self.states = np.zeros(64, dtype=np.int64)  # expanded states, in expansion order
        self.blocks = np.zeros((16, 2), dtype=np.int64)  # learnt (blocking parts, part bit)
        self.n_blocks = 0
        self.accepted: dict[int, int] = {}  # per state, the steps the checks accepted
        self.goal = _Node(self.full, np.zeros(self.n), self.n, 0.0)
        self.goal.alive = True
        self.events: list[SearchEvent] = []
        self.first: tuple[int, float] | None = None
        self.n_orders = 0

    # The frontier ----------------------------------------------------------------------------

    def _push(self, node: _Node) -> None:
        """Queue the node's next untried step (each node has at most one entry in the heap)."""
        if node.pos >= len(node.order):
            return
        score = float(node.row[node.order[node.pos]])
        depth = node.state.bit_count()
        if self.config.frontier == Frontier.greedy:
            key = (-depth, -score)
        else:
            key = (-(node.logp + _log(score)), -depth)
        self.pushes += 1
        heapq.heappush(self.heap, (*key, self.pushes, node.state))

    def _expand(self, state: int, logp: float) -> _Node:
        node = _Node(state, np.asarray(self.scores(state), dtype=np.float64), self.n, logp)
        self.nodes[state] = node
        count = len(self.nodes)
        if count > len(self.states):
            self.states = np.concatenate([self.states, np.zeros_like(self.states)])
        self.states[count - 1] = state
        self._push(node)
        return node

    # What is known ---------------------------------------------------------------------------

    def _ruled_out(self, state: int) -> tuple[int, int] | None:
        """The first learnt block that rules `state` out (it holds the blocking parts, not the
        part) as (blocking parts, part); None if none does."""
        blocks = self.blocks[: self.n_blocks]
        hit = ((state & blocks[:, 0]) == blocks[:, 0]) & ((state & blocks[:, 1]) == 0)
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
        """`part` is blocked for good once `blocking` is placed: every expanded state holding
        `blocking` but not `part` is dead (`node`, where the refusal came, among them)."""
        bit = 1 << part
        if self.n_blocks == len(self.blocks):
            self.blocks = np.concatenate([self.blocks, np.zeros_like(self.blocks)])
        self.blocks[self.n_blocks] = (blocking, bit)
        self.n_blocks += 1
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
        """Verified orders: paths from the empty state to the goal through alive states."""
        alive = sorted(
            (n for n in self.nodes.values() if n.alive), key=lambda n: n.state.bit_count()
        )
        paths = {0: 1}
        for node in [*alive, self.goal]:
            if node.state:
                paths[node.state] = sum(paths.get(s, 0) for s, _ in node.parents)
        return paths.get(self.full, 0)

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
        """The check accepted `part` in `node`'s state: follow the step."""
        child_state = node.state | 1 << part
        self.accepted[node.state] = self.accepted.get(node.state, 0) | 1 << part
        self.events.append(SearchEvent("placed", node.state, part, self.oracle.checks))
        if child_state == self.full:
            child = self.goal
        else:
            child = self.nodes.get(child_state)
            if child is None:
                block = self._ruled_out(child_state) if self.config.learn_blocks else None
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
        if child.dead:
            self._step_dead(node)
        elif child.alive:
            if self.first is None:
                self.first = (self.oracle.checks, time.perf_counter() - start)
            self._revive(node)
            self.n_orders = 1 if self.config.k == 1 else self._count_orders()

    def run(self) -> SearchResult:
        start = time.perf_counter()
        root = self._expand(0, 0.0)
        out_of_budget = False
        while self.heap and not root.dead and not self._enough():
            *_, state = heapq.heappop(self.heap)
            node = self.nodes[state]
            if node.dead:
                continue
            part = node.order[node.pos]
            if self._out_of_budget(start):
                out_of_budget = True
                break
            node.pos += 1
            self._push(node)
            verdict = self.oracle.check(state, part)
            if verdict.feasible:
                self._take(node, part, start)
                continue
            blocking = verdict.blocked_by
            self.events.append(SearchEvent("refused", state, part, self.oracle.checks, blocking))
            if self.config.learn_blocks and blocking is not None:
                self._learn(blocking, part, node)
            else:
                self._step_dead(node)
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
            checks=self.oracle.checks,
            seconds=seconds,
            first_checks=first_checks,
            first_seconds=first_seconds,
            expanded=len(self.nodes),
            verified=self._verified(),
            exhausted=exhausted,
            events=self.events,
        )

    # Results ---------------------------------------------------------------------------------

    def _alive_steps(self) -> dict[int, int]:
        """Per state, the bitmask of its steps on verified orders."""
        steps: dict[int, int] = {}
        for node in [*self.nodes.values(), self.goal]:
            if node.alive:
                for state, part in node.parents:
                    steps[state] = steps.get(state, 0) | 1 << part
        return steps

    def _best_orders(self) -> list[Ranked]:
        """The k most probable verified orders: A* over the verified steps, with the exact
        best completion of each state as the bound (every verified step completes)."""
        steps = self._alive_steps()
        if 0 not in steps:
            return []
        rest = {self.full: 0.0}  # best log-probability still to come
        for state in sorted(steps, key=int.bit_count, reverse=True):
            row = self.nodes[state].row
            rest[state] = max(
                _log(float(row[p])) + rest[state | 1 << p]
                for p in range(self.n)
                if steps[state] >> p & 1
            )
        heap: list[tuple[float, int, tuple[int, ...], float]] = [(-rest[0], 0, (), 0.0)]
        out: list[Ranked] = []
        pushes = 0
        while heap and (self.config.k is None or len(out) < self.config.k):
            _, _, prefix, logp = heapq.heappop(heap)
            state = sum(1 << p for p in prefix)
            if state == self.full:
                probs = tuple(float(self.nodes[s].row[p]) for s, p in _prefix_steps(prefix))
                out.append(Ranked(prefix, float(np.prod(probs)), probs))
                continue
            row = self.nodes[state].row
            for part in range(self.n):
                if steps[state] >> part & 1:
                    step = logp + _log(float(row[part]))
                    pushes += 1
                    key = -(step + rest[state | 1 << part])
                    heapq.heappush(heap, (key, pushes, (*prefix, part), step))
        return out

    def _verified(self) -> GroundTruth:
        nodes = [*self.nodes.values(), *([self.goal] if self.goal.parents else [])]
        placeable = {n.state: self.accepted.get(n.state, 0) for n in nodes}
        completable = {n.state: 0 for n in nodes}
        for node in nodes:
            if node.alive:
                for state, part in node.parents:
                    completable[state] |= 1 << part
        states = np.array(sorted(placeable), dtype=np.int64)
        return GroundTruth(
            n_parts=self.n,
            states=states,
            placeable=np.array([placeable[s] for s in states.tolist()], dtype=np.int64),
            completable=np.array([completable[s] for s in states.tolist()], dtype=np.int64),
        )


def _prefix_steps(order: tuple[int, ...]) -> list[tuple[int, int]]:
    """(state before, part) of each step of `order`."""
    out, state = [], 0
    for part in order:
        out.append((state, part))
        state |= 1 << part
    return out
