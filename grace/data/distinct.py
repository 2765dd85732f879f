"""A data set that shares no assembly with another (docs/training.md, "Selection and evaluation").

The selection data set (seed 1) chooses every default; the evaluation data set (seed 0) reports
the figures. Both are drawn from one generator, so without care they share assemblies: small
sizes have few layouts (147 of the 500 A3 of seed 1 are exact copies of seed-0 A3). A choice
made on a copy is a choice made on the evaluation set. Here every assembly whose canonical form
(grace/domain/canonical.py: same part types at the same poses, the same ground truth, in any
numbering) is in the other data set is replaced by the next draw of its size that is not: the
data set keeps its size → count, and is the first `count` draws of each size that are no copies,
in index order, however many rounds of drawing it took.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from grace.domain.canonical import assembly_key
from grace.errors import UserError

log = logging.getLogger(__name__)

T = TypeVar("T")
Draws = Callable[[dict[int, int]], list[T]]
"""`draws(sizes)`: the first `count` assemblies of each size of a data set, index order (each
with a `size`: labelled ones, or self-training's unlabelled draws)."""

MAX_DRAWS_FACTOR = 10
"""Stop after this many times the wanted count of a size has been drawn: the other data set then
holds nearly every layout of that size, and no amount of drawing gives enough new ones."""


def distinct_from(
    draws: Draws[T],
    sizes: dict[int, int],
    reference: Sequence[Any],
    key: Callable[[Any], str] = assembly_key,
) -> list[T]:
    """The first `sizes[n]` assemblies of each size n of `draws` whose `key` (default: the
    canonical form, ground truth included) is no assembly's of `reference`, sizes ascending,
    each in index order.

    Draws more of a size, in rounds, until enough are left; UserError when a size would need more
    than `MAX_DRAWS_FACTOR` times its count.
    """
    taken = {key(sample) for sample in reference}
    drawn = dict(sizes)
    while True:
        data = draws(drawn)
        kept: dict[int, list[T]] = {n: [] for n in sizes}
        copies = dict.fromkeys(sizes, 0)
        for sample in data:
            if len(kept[sample.size]) == sizes[sample.size]:
                continue
            if key(sample) in taken:
                copies[sample.size] += 1
            else:
                kept[sample.size].append(sample)
        short = {n: sizes[n] - len(kept[n]) for n in sizes if len(kept[n]) < sizes[n]}
        if not short:
            break
        over = [n for n in short if drawn[n] >= MAX_DRAWS_FACTOR * sizes[n]]
        if over:
            raise UserError(
                f"dataset.distinct_from: after {drawn[over[0]]} draws of A{over[0]} only "
                f"{len(kept[over[0]])} of {sizes[over[0]]} are no copies of the other data set's; "
                f"fix: ask fewer A{over[0]} (dataset.sizes) or drop dataset.distinct_from"
            )
        # The copies among the new draws are about as frequent as among the old ones.
        drawn.update({n: drawn[n] + short[n] * drawn[n] // max(len(kept[n]), 1) for n in short})
    if any(copies.values()):
        log.info("copies of the other data set's assemblies replaced by new draws: %s", copies)
    return [sample for n in sorted(sizes) for sample in kept[n]]
