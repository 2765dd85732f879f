"""Fold splits of the paper's protocols (Sec. V-B, docs/protocols.md): intra-sized, many-to-one
and one-to-many.

All three use one rule: the assemblies are split into `folds` parts with a fixed seed, stratified
by size; fold f tests on its own assemblies of the test sizes and trains on the other folds'
assemblies of the train sizes. Validation (`val_fraction`) is drawn from the training part only,
so no assembly ever appears in two of train, validation and test. Copies of one assembly (the
same parts, poses and ground truth, in any numbering: grace/domain/canonical.py) are one group,
dealt whole to one fold and to one of train and validation, so no copy of a test assembly is
trained on.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from omegaconf import MISSING

from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.roles import WEIGHTS


@dataclass
class ProtocolSettings:
    """Schema of the `protocol` group (docs/protocols.md); sizes None = all in the data set."""

    name: str = field(default=MISSING, metadata=WEIGHTS)
    folds: int = field(default=MISSING, metadata=WEIGHTS)
    val_fraction: float = field(default=MISSING, metadata=WEIGHTS)
    seed: int = field(default=MISSING, metadata=WEIGHTS)
    train_sizes: list[int] | None = field(default=MISSING, metadata=WEIGHTS)
    test_sizes: list[int] | None = field(default=MISSING, metadata=WEIGHTS)
    train_exclude: list[int] = field(default=MISSING, metadata=WEIGHTS)
    test_exclude: list[int] = field(default=MISSING, metadata=WEIGHTS)


@dataclass(frozen=True)
class Fold:
    """Indices into the data set of one cross-validation fold."""

    index: int
    train: tuple[int, ...]
    val: tuple[int, ...]
    test: tuple[int, ...]


def protocol_sizes(
    name: str,
    available: Sequence[int],
    train_sizes: Sequence[int] | None = None,
    test_sizes: Sequence[int] | None = None,
    train_exclude: Sequence[int] = (),
    test_exclude: Sequence[int] = (),
) -> tuple[list[int], list[int]]:
    """Train and test sizes of a protocol: the listed sizes (`None` = all available) minus the
    excluded ones (many-to-one excludes the test size from training, one-to-many the train size
    from testing)."""
    available = sorted(set(available))
    train = sorted(set(available if train_sizes is None else train_sizes) - set(train_exclude))
    test = sorted(set(available if test_sizes is None else test_sizes) - set(test_exclude))
    missing = sorted((set(train) | set(test)) - set(available))
    if missing:
        raise UserError(
            f"protocol {name}: sizes {missing} are not in the data set (sizes {available}); "
            "fix: set protocol.train_sizes/test_sizes (or train_size/test_size) to sizes it holds"
        )
    if not train or not test:
        raise UserError(
            f"protocol {name}: no {'train' if not train else 'test'} size left of {available}; "
            "fix: check protocol.train_sizes/test_sizes and train_size/test_size"
        )
    return train, test


def make_folds(
    sizes: Sequence[int],
    train_sizes: Sequence[int],
    test_sizes: Sequence[int],
    folds: int,
    val_fraction: float,
    seed: int,
    groups: Sequence[int] | None = None,
) -> list[Fold]:
    """Size-stratified k-fold split over assemblies (`sizes[i]` = size of assembly i).

    `groups[i]` (default: every assembly its own) names the group of assembly i, e.g. the first
    of its copies (grace.domain.canonical.copy_groups): a group goes whole to one fold, the
    groups of a size dealt in a seeded order each to the fold holding fewest of that size so
    far (round-robin when no assembly has a copy), and whole to train or validation."""
    check_split(folds, val_fraction)
    rng = np.random.default_rng(seed)
    sizes = np.asarray(sizes)
    groups = np.arange(len(sizes)) if groups is None else np.asarray(groups)
    fold_of = np.empty(len(sizes), dtype=np.int64)
    for size in np.unique(sizes):
        held = np.zeros(folds, dtype=np.int64)
        for group in rng.permutation(np.unique(groups[sizes == size])):
            members = groups == group
            f = int(np.argmin(held))
            fold_of[members], held[f] = f, held[f] + members.sum()
    train_ok, test_ok = np.isin(sizes, train_sizes), np.isin(sizes, test_sizes)
    out = []
    for f in range(folds):
        train = np.flatnonzero((fold_of != f) & train_ok)
        val = _validation(train, sizes, groups, val_fraction, rng)
        out.append(
            Fold(
                index=f,
                train=tuple(int(i) for i in np.setdiff1d(train, val)),
                val=tuple(int(i) for i in val),
                test=tuple(int(i) for i in np.flatnonzero((fold_of == f) & test_ok)),
            )
        )
    return out


def check_split(folds: int, val_fraction: float) -> None:
    """Raise a UserError unless `folds` and `val_fraction` make a cross-validation."""
    if folds < 2:
        raise UserError(
            f"protocol.folds={folds}: cross-validation needs at least 2 folds; "
            "fix: protocol.folds=2"
        )
    if not 0.0 <= val_fraction < 1.0:
        raise UserError(
            f"protocol.val_fraction={val_fraction} is outside [0, 1); fix: protocol.val_fraction=0"
            " (the share of training assemblies kept for validation)"
        )


def check_fold_sizes(
    name: str,
    counts: dict[int, int],
    train_sizes: Sequence[int],
    test_sizes: Sequence[int],
    folds: int,
    val_fraction: float,
) -> None:
    """Raise a UserError if a fold of :func:`make_folds` would have no test or no training
    assembly, from the number of assemblies per size alone (before any is made or loaded).

    make_folds deals each size's assemblies round-robin, so fold f holds
    `n // folds + (f < n % folds)` of a size with n assemblies.
    """
    check_split(folds, val_fraction)
    empty = _empty_fold(counts, train_sizes, test_sizes, folds, val_fraction)
    if empty is None:
        return
    f, test, train = empty
    fits = [
        k
        for k in range(folds - 1, 1, -1)
        if not _empty_fold(counts, train_sizes, test_sizes, k, val_fraction)
    ]
    fix = f"protocol.folds={fits[0]}" if fits else "a larger data set (dataset.sizes or scale)"
    held = {s: counts.get(s, 0) for s in sorted(set(train_sizes) | set(test_sizes))}
    raise UserError(
        f"protocol {name}: protocol.folds={folds} leaves fold {f} with {test} test and {train} "
        f"training assemblies (assemblies per size {held}, test sizes {sorted(test_sizes)}, "
        f"each size dealt round-robin to the folds); fix: {fix}"
    )


def _empty_fold(
    counts: dict[int, int],
    train_sizes: Sequence[int],
    test_sizes: Sequence[int],
    folds: int,
    val_fraction: float,
) -> tuple[int, int, int] | None:
    """The first fold without test or training assemblies, with those numbers, or None."""
    for f in range(folds):
        held = {size: n // folds + (f < n % folds) for size, n in counts.items()}
        test = sum(held[s] for s in test_sizes if s in held)
        fit = [counts[s] - held[s] for s in train_sizes if s in counts]
        train = sum(n - round(val_fraction * n) for n in fit)
        if not test or not train:
            return f, test, train
    return None


def _validation(
    train: np.ndarray,
    sizes: np.ndarray,
    groups: np.ndarray,
    fraction: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """Per size a seeded `fraction` of the training assemblies, whole groups: groups in a
    seeded order until that many are picked."""
    picked = []
    for size in np.unique(sizes[train]):
        members = train[sizes[train] == size]
        want, taken = round(fraction * len(members)), []
        for group in rng.permutation(np.unique(groups[members])):
            if len(taken) >= want:
                break
            taken.extend(members[groups[members] == group])
        picked.append(np.asarray(taken, dtype=np.int64))
    return np.sort(np.concatenate(picked)) if picked else np.zeros(0, dtype=np.int64)


def training_subset(
    samples: Sequence[LabelledAssembly], feasible_only: bool
) -> list[LabelledAssembly]:
    """The assemblies a model trains (and early-stops) on: all, or only the feasible ones for the
    paper's ablation "#sequences, feasible only" (Sec. V-B.3, Fig. 5)."""
    return [s for s in samples if s.truth.feasible or not feasible_only]


def split_assemblies(
    samples: list[LabelledAssembly], test_fraction: float, val_fraction: float, seed: int
) -> tuple[list[LabelledAssembly], list[LabelledAssembly], list[LabelledAssembly]]:
    """(train, val, test) split per size, seeded; sizes with ≥ 3 assemblies get a test share."""
    for name, f in (("test_fraction", test_fraction), ("val_fraction", val_fraction)):
        if not 0.0 <= f < 1.0:
            raise UserError(f"task.{name}={f} is outside [0, 1); fix: task.{name}=0.15")
    rng = np.random.default_rng(seed)
    train, val, test = [], [], []
    for size in sorted({s.size for s in samples}):
        group = [s for s in samples if s.size == size]
        order = rng.permutation(len(group))
        n_test = round(test_fraction * len(group)) if len(group) >= 3 else 0
        n_val = round(val_fraction * (len(group) - n_test)) if len(group) >= 3 else 0
        test += [group[i] for i in order[:n_test]]
        val += [group[i] for i in order[n_test : n_test + n_val]]
        train += [group[i] for i in order[n_test + n_val :]]
    return train, val, test
