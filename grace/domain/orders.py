"""Assembly orders as a DAG over states (paper Sec. III; docs/metrics.md).

A state is a bitmask of placed parts (bit i = part i). Listing every complete order costs N!, but
the orders of an assembly are exactly the paths of a DAG with at most 2^N nodes: for every state
reachable from the empty one we keep which parts can be placed next (`placeable`) and which of
those still lead to a complete assembly (`completable`, the next-step labels, docs/metrics.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from grace.domain.assembly import full_mask, mask_to_parts


@dataclass(eq=False)
class GroundTruth:
    """All feasible orders of one assembly, stored as the reachable-state DAG.

    `states` is sorted ascending; `placeable[i]` and `completable[i]` are part bitmasks for
    `states[i]`. `checks` counts the placement checks the enumeration ran, `naive_checks` those a
    brute force over all N! orders (each checked step by step until its first infeasible step)
    would have run.
    """

    n_parts: int
    states: np.ndarray
    placeable: np.ndarray
    completable: np.ndarray
    checks: int = 0
    naive_checks: int = 0

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, GroundTruth)
            and self.n_parts == other.n_parts
            and np.array_equal(self.states, other.states)
            and np.array_equal(self.placeable, other.placeable)
            and np.array_equal(self.completable, other.completable)
        )

    @classmethod
    def explore(cls, n_parts: int, can_place: Callable[[int, int], bool]) -> GroundTruth:
        """Enumerate the reachable states with a placement check `can_place(state, part)`.

        Each (state, part) pair is checked once, so the work is O(2^N · N) checks instead of the
        O(N · N!) of listing orders.
        """

        def vectorised(states: np.ndarray, part: int) -> np.ndarray:
            return np.array([bool(can_place(int(s), part)) for s in states], dtype=bool)

        return cls.explore_many(n_parts, vectorised)

    @classmethod
    def explore_many(
        cls,
        n_parts: int,
        can_place: Callable[[np.ndarray, int], np.ndarray],
        naive_checks: bool = True,
    ) -> GroundTruth:
        """:meth:`explore` with a check over many states at once: `can_place(states, part)`
        returns a bool array for an int64 array of states that all lack `part`. The simulator's
        rules are bitmask tests, so one numpy call per (layer, part) replaces a Python call per
        (state, part), which large assemblies (2^16 states) need. `naive_checks=False` skips
        counting the brute force's checks (ablations compare orders only)."""
        frontier = np.zeros(1, dtype=np.int64)
        states, placeable = [], []
        checks = 0
        while frontier.size:
            mask = np.zeros_like(frontier)
            children = []
            for part in range(n_parts):
                bit = np.int64(1) << part
                free = np.flatnonzero((frontier & bit) == 0)
                checks += free.size
                if free.size:
                    ok = free[np.asarray(can_place(frontier[free], part), dtype=bool)]
                    mask[ok] |= bit
                    children.append(frontier[ok] | bit)
            states.append(frontier)
            placeable.append(mask)
            frontier = np.unique(np.concatenate(children)) if children else frontier[:0]
        gt = cls._from_arrays(
            n_parts, np.concatenate(states), np.concatenate(placeable), naive_checks
        )
        gt.checks = checks
        return gt

    @classmethod
    def from_orders(
        cls, n_parts: int, orders: Sequence[Sequence[int]], dead_ends: Sequence[Sequence[int]] = ()
    ) -> GroundTruth:
        """The DAG spanned by listed complete orders and dead-end partial orders (raw imports)."""
        full = full_mask(n_parts)
        placeable: dict[int, int] = {}
        for order in [*orders, *dead_ends]:
            state = 0
            for part in order:
                placeable[state] = placeable.get(state, 0) | 1 << part
                state |= 1 << part
            placeable.setdefault(state, 0)
        placeable.setdefault(0, 0)
        if orders:
            placeable.setdefault(full, 0)
        keys = np.array(list(placeable), dtype=np.int64)
        return cls._from_arrays(n_parts, keys, np.array(list(placeable.values()), dtype=np.int64))

    @classmethod
    def _from_arrays(
        cls, n_parts: int, states: np.ndarray, placeable: np.ndarray, naive_checks: bool = True
    ) -> GroundTruth:
        order = np.argsort(states, kind="stable")
        states, placeable = states[order].astype(np.int64), placeable[order].astype(np.int64)
        full = full_mask(n_parts)
        count = np.bitwise_count(states)
        good = states == full
        completable = np.zeros_like(placeable)
        # Supersets have more bits: walk the layers from full towards empty.
        for k in range(n_parts - 1, -1, -1):
            idx = np.flatnonzero(count == k)
            if not idx.size:
                continue
            for part, pos, has in _children(states, placeable, idx, n_parts):
                ok = good[pos]
                completable[idx[has][ok]] |= np.int64(1) << part
            good[idx] = completable[idx] != 0
        gt = cls(n_parts=n_parts, states=states, placeable=placeable, completable=completable)
        if naive_checks:
            gt.naive_checks = gt._naive_checks()
        return gt

    @property
    def feasible(self) -> bool:
        return bool(self.completable[0]) if self.states[0] == 0 else False

    def label(self, state: int) -> int:
        """Next-step label mask of `state`: parts whose placement still allows completion."""
        pos = int(np.searchsorted(self.states, state))
        if pos >= len(self.states) or self.states[pos] != state:
            raise KeyError(state)
        return int(self.completable[pos])

    def is_order(self, sequence: Sequence[int]) -> bool:
        """Whether `sequence` is one of the orders: each step valid in the state it leaves (a
        valid step always enters a state of the DAG)."""
        if not self.feasible:
            return False
        state = 0
        for part in sequence:
            if not self.label(state) >> part & 1:
                return False
            state |= 1 << part
        return len(sequence) == self.n_parts

    def order_states(self) -> np.ndarray:
        """The decision states of the ground-truth orders (step-AUC test states, docs/metrics.md).

        Every non-complete state on some complete order; for an infeasible assembly the empty
        state, whose labels are all 0 (no first part leads to completion). These are the states
        the original data (`solutions.csv`) describes.
        """
        if not self.feasible:
            return np.zeros(1, dtype=np.int64)
        keep = (self.completable != 0) & (self.states != full_mask(self.n_parts))
        return self.states[keep].astype(np.int64)

    def _counts(self, masks: np.ndarray) -> np.ndarray:
        """Number of paths from the empty state to each state along `masks` (int64 per state)."""
        counts = np.zeros(len(self.states), dtype=np.int64)
        if not len(self.states) or self.states[0] != 0:
            return counts
        counts[0] = 1
        count = np.bitwise_count(self.states)
        for k in range(self.n_parts):
            idx = np.flatnonzero(count == k)
            for _, pos, has in _children(self.states, masks, idx, self.n_parts):
                np.add.at(counts, pos, counts[idx[has]])
        return counts

    def path_counts(self, mask_of: str = "placeable") -> dict[int, int]:
        """Number of paths from the empty state to each state along `placeable` or `completable`."""
        counts = self._counts(getattr(self, mask_of))
        keep = counts > 0
        return dict(zip(self.states[keep].tolist(), counts[keep].tolist(), strict=True))

    def n_orders(self) -> int:
        """Number of complete feasible orders, without listing them."""
        full = full_mask(self.n_parts)
        if self.states[-1] != full:
            return 0
        return int(self._counts(self.completable)[-1])

    def same_orders(self, other: GroundTruth) -> bool:
        """True if both have the same set of complete orders (compared as DAGs, not lists)."""
        mine, theirs = self._order_dag(), other._order_dag()
        return all(np.array_equal(a, b) for a, b in zip(mine, theirs, strict=True))

    def _order_dag(self) -> tuple[np.ndarray, np.ndarray]:
        cached = self.__dict__.get("_dag")
        if cached is not None and cached[0] is self.completable:
            return cached[1]
        on = self._counts(self.completable) > 0
        on &= (self.completable != 0) | (self.states == full_mask(self.n_parts))
        dag = (self.states[on], self.completable[on])
        self.__dict__["_dag"] = (self.completable, dag)
        return dag

    def _naive_checks(self) -> int:
        counts = self._counts(self.placeable)
        remaining = self.n_parts - np.bitwise_count(self.states)
        factorial = np.array([math.factorial(k) for k in range(self.n_parts + 1)], dtype=np.int64)
        keep = self.states != full_mask(self.n_parts)
        return int(np.sum(counts[keep] * factorial[remaining[keep]]))

    def orders(self, limit: int | None = None) -> Iterator[tuple[int, ...]]:
        """Complete feasible orders in lexicographic order (at most `limit`)."""
        masks = dict(zip(self.states.tolist(), self.completable.tolist(), strict=True))
        full = full_mask(self.n_parts)
        emitted = 0
        stack: list[tuple[int, tuple[int, ...]]] = [(0, ())]
        while stack:
            state, prefix = stack.pop()
            nxt = masks.get(state, 0)
            if not nxt:
                if state == full:
                    yield prefix
                    emitted += 1
                    if limit is not None and emitted >= limit:
                        return
                continue
            for part in reversed(mask_to_parts(nxt)):
                stack.append((state | 1 << part, (*prefix, part)))

    def dead_ends(self) -> Iterator[tuple[int, ...]]:
        """Partial orders that end where no part can be placed and together take every
        placement step no complete order takes (`inter_solutions.csv`, docs/raw-format.md):
        with the complete orders they span the whole DAG, so it imports back exactly.

        Not every dead-end path, whose number grows factorially with the parts, but at most one
        per such step: a depth-first walk, parts in ascending order, that expands each state
        once and ends a path at a dead end, or where it enters an already expanded state off the
        complete orders, completed there by the lowest placeable parts. Paths come out in
        lexicographic order, one at a time; the walk keeps one entry per state.
        """
        placeable = dict(zip(self.states.tolist(), self.placeable.tolist(), strict=True))
        completable = dict(zip(self.states.tolist(), self.completable.tolist(), strict=True))
        full = full_mask(self.n_parts)

        def lowest_to_a_dead_end(state: int) -> list[int]:
            parts = []
            while nxt := placeable[state]:
                part = (nxt & -nxt).bit_length() - 1
                parts.append(part)
                state |= 1 << part
            return parts

        path: list[int] = []
        expanded = {0}
        stack = [(0, iter(mask_to_parts(placeable.get(0, 0))))]
        while stack:
            state, parts = stack[-1]
            part = next(parts, None)
            if part is None:
                stack.pop()
                if path:
                    path.pop()
                continue
            child = state | 1 << part
            off = child != full and not completable[child]  # no complete order goes on
            if child in expanded:
                if off:
                    yield (*path, part, *lowest_to_a_dead_end(child))
                continue
            expanded.add(child)
            if placeable[child]:
                path.append(part)
                stack.append((child, iter(mask_to_parts(placeable[child]))))
            elif off:
                yield (*path, part)


def _children(
    states: np.ndarray, masks: np.ndarray, idx: np.ndarray, n_parts: int
) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Per part: (part, positions in `states` of the children of `states[idx]` along `masks`,
    which of `idx` have that child). `states` is sorted; children missing from it are dropped."""
    for part in range(n_parts):
        bit = np.int64(1) << part
        has = (masks[idx] & bit) != 0
        if not has.any():
            continue
        child = states[idx[has]] | bit
        pos = np.minimum(np.searchsorted(states, child), len(states) - 1)
        found = states[pos] == child
        if not found.all():
            has[np.flatnonzero(has)[~found]] = False
            pos = pos[found]
        yield part, pos, has
