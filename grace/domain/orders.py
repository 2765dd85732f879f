"""Assembly orders as a DAG over states (SPEC §1, §6).

A state is a bitmask of placed parts (bit i = part i). Listing every complete order costs N!, but
the orders of an assembly are exactly the paths of a DAG with at most 2^N nodes: for every state
reachable from the empty one we keep which parts can be placed next (`placeable`) and which of
those still lead to a complete assembly (`completable`, the next-step labels of SPEC §7).
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
        full = full_mask(n_parts)
        placeable: dict[int, int] = {}
        frontier = [0]
        checks = 0
        while frontier:
            nxt = set()
            for state in frontier:
                mask = 0
                for part in range(n_parts):
                    if not state >> part & 1:
                        checks += 1
                        if can_place(state, part):
                            mask |= 1 << part
                            nxt.add(state | 1 << part)
                placeable[state] = mask
            frontier = sorted(nxt)
        gt = cls._from_placeable(n_parts, placeable, full)
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
        return cls._from_placeable(n_parts, placeable, full)

    @classmethod
    def _from_placeable(cls, n_parts: int, placeable: dict[int, int], full: int) -> GroundTruth:
        states = np.array(sorted(placeable), dtype=np.int64)
        good = {full} if full in placeable else set()
        completable: dict[int, int] = {}
        # Supersets come later in popcount order: walk states from full towards empty.
        for state in sorted(placeable, key=lambda s: -s.bit_count()):
            mask = 0
            for part in mask_to_parts(placeable[state]):
                if state | 1 << part in good:
                    mask |= 1 << part
            completable[state] = mask
            if mask:
                good.add(state)
        gt = cls(
            n_parts=n_parts,
            states=states,
            placeable=np.array([placeable[s] for s in states], dtype=np.int64),
            completable=np.array([completable[s] for s in states], dtype=np.int64),
        )
        gt.naive_checks = gt._naive_checks()
        return gt

    @property
    def feasible(self) -> bool:
        return bool(self.completable[0]) if self.states[0] == 0 else False

    def _index(self) -> dict[int, int]:
        return {int(s): i for i, s in enumerate(self.states)}

    def label(self, state: int) -> int:
        """Next-step label mask of `state`: parts whose placement still allows completion."""
        return int(self.completable[self._index()[state]])

    def order_states(self) -> np.ndarray:
        """The decision states of the ground-truth orders (SPEC §7 step-AUC test states).

        Every non-complete state on some complete order; for an infeasible assembly the empty
        state, whose labels are all 0 (no first part leads to completion). These are the states
        the original data (`solutions.csv`) describes.
        """
        if not self.feasible:
            return np.zeros(1, dtype=np.int64)
        keep = (self.completable != 0) & (self.states != full_mask(self.n_parts))
        return self.states[keep].astype(np.int64)

    def path_counts(self, mask_of: str = "placeable") -> dict[int, int]:
        """Number of paths from the empty state to each state along `placeable` or `completable`."""
        masks = dict(zip(self.states.tolist(), getattr(self, mask_of).tolist(), strict=True))
        counts = {0: 1}
        for state in sorted(masks, key=int.bit_count):
            c = counts.get(state, 0)
            if not c:
                continue
            for part in mask_to_parts(masks[state]):
                counts[state | 1 << part] = counts.get(state | 1 << part, 0) + c
        return counts

    def n_orders(self) -> int:
        """Number of complete feasible orders, without listing them."""
        return self.path_counts("completable").get(full_mask(self.n_parts), 0)

    def _naive_checks(self) -> int:
        counts = self.path_counts("placeable")
        return sum(
            c * math.factorial(self.n_parts - s.bit_count())
            for s, c in counts.items()
            if s != full_mask(self.n_parts)
        )

    def orders(self, limit: int | None = None) -> Iterator[tuple[int, ...]]:
        """Complete feasible orders in lexicographic order (at most `limit`)."""
        yield from self._paths("completable", complete=True, limit=limit)

    def dead_ends(self, limit: int | None = None) -> Iterator[tuple[int, ...]]:
        """Partial orders that reach a state where no part can be placed (SPEC §3)."""
        yield from self._paths("placeable", complete=False, limit=limit)

    def _paths(self, mask_of: str, complete: bool, limit: int | None) -> Iterator[tuple[int, ...]]:
        masks = dict(zip(self.states.tolist(), getattr(self, mask_of).tolist(), strict=True))
        full = full_mask(self.n_parts)
        emitted = 0
        stack: list[tuple[int, tuple[int, ...]]] = [(0, ())]
        while stack:
            state, prefix = stack.pop()
            nxt = masks.get(state, 0)
            if not nxt:
                if (state == full) == complete and (complete or prefix or state == 0):
                    yield prefix
                    emitted += 1
                    if limit is not None and emitted >= limit:
                        return
                continue
            for part in reversed(mask_to_parts(nxt)):
                stack.append((state | 1 << part, (*prefix, part)))
