"""Per-state training samples of labelled assemblies, batched by assembly (docs/training.md).

A sample is one state of one assembly with its next-step labels (the `completable` mask: a part
is a valid next step iff placing it still allows completion). `states="orders"` (default) takes
the decision states of the ground-truth orders, the same states the step AUC tests
(`GroundTruth.order_states`): each infeasible assembly contributes its empty state with all-zero
labels, which is what lets "no complete sequence found" predict infeasibility. `states="reachable"`
adds every state the placement checks reach, dead ends included (all labels 0 there), which asks
the network to look ahead. The final state (all parts placed) is no decision and is left out.

`balance_steps=True` (not in the paper; its suggested remedy for early-step failures, Sec. V-C)
weights each training state's loss by the inverse frequency of its step index (the number of
placed parts) among the training states of assemblies of its size, so that every step of a size
carries the same total weight: the one empty state per assembly otherwise counts as little as one
of the many mid-sequence states. Weights have mean 1 per size; validation stays unweighted.

`dead_end_target=t` (not in the paper; 0 keeps its labels) grades the labels: a part whose
placement is physically feasible but leads to a dead end (the ground truth's `placeable` but not
`completable`) gets the target t instead of 0, in training and validation alike. With 0 < t < λ
the planner does not take such a part as long as its score stays at or below the next-step
output (model.net.score, docs/training.md) and the output learns t (the dead-end pass rate
measures it), and the network learns to rank feasible placements above infeasible ones in every
state, including the dead ends the planner enters after a wrong step (the placeable AUC
off-path, docs/metrics.md). The step AUCs still count only
label 1 as positive. `dead_end_weight=w` scales the training loss of every state from which no
order completes (all its labels 0: the dead ends `states="reachable"` adds, and the states of an
infeasible assembly), so that at large sizes, where they outnumber the states on the true orders,
they do not drown them; validation stays unweighted.

A partial label (`LabelledAssembly.known`: self-training's labels from a verified search,
grace/planning/self_labels.py) names per state the parts whose label is known; batches of a data
set holding one leave the other parts out of `mask`, so the loss (and the logged step AUC) reads
none of their targets.

With `mixing="assembly"` (default) batches hold about `batch_size` states drawn from whole
assemblies (large ones split into chunks), so that the fast path computes each surface embedding
once per batch. `mixing="state"` draws states independently, as the reference's shuffled
per-state data set does; batches then span many assemblies (states of one assembly still share
its embedding within a batch). The collate function, given by the network's implementation
(`model.impl`), builds what that path consumes (grace/graphs/batches.py): per-state PyG graphs
or padded per-assembly tensors.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from enum import StrEnum
from functools import partial
from typing import Any

import lightning.pytorch as pl
import numpy as np
import torch
from torch.utils.data import DataLoader, Sampler

from grace.domain.assembly import full_mask
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.graphs.assembly_graph import AssemblyTensors, encode_assembly, state_flags
from grace.graphs.batches import Collate, StateBatch, collate_dense
from grace.graphs.encoding import GraphEncoding


class StateSet(StrEnum):
    """Which states of an assembly are training samples (`datamodule.states`)."""

    orders = "orders"
    reachable = "reachable"


class Mixing(StrEnum):
    """How batches mix states (`datamodule.mixing`); see the module docstring."""

    assembly = "assembly"
    state = "state"


def state_masks(truth: GroundTruth, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(valid next parts, feasible dead-end parts) of `states` as part bitmasks: the ground
    truth's where it has the state, none where it does not (a state reached through an infeasible
    placement completes nothing and is no placement check's)."""
    states = np.asarray(states, dtype=np.int64)
    where = np.clip(np.searchsorted(truth.states, states), 0, len(truth.states) - 1)
    known = truth.states[where] == states
    completable = np.where(known, truth.completable[where], 0).astype(np.int64)
    placeable = np.where(known, truth.placeable[where], 0).astype(np.int64)
    return completable, placeable & ~completable


def _order_states(truth: GroundTruth) -> np.ndarray:
    return truth.order_states()


def _reachable_states(truth: GroundTruth) -> np.ndarray:
    return truth.states[truth.states != full_mask(truth.n_parts)]


_STATE_SETS = {StateSet.orders: _order_states, StateSet.reachable: _reachable_states}


def step_weights(
    samples: Sequence[LabelledAssembly], states: Sequence[np.ndarray]
) -> list[np.ndarray]:
    """Per-state loss weights balancing step indices within each size (`balance_steps`).

    A state of step t in an N-part assembly weighs (states of size N) / (steps of size N seen ·
    states of size N at step t): each step's total is equal and the mean per size is 1.
    """
    steps = [np.bitwise_count(np.asarray(s, dtype=np.int64)) for s in states]
    sizes = [sample.assembly.n_parts for sample in samples]
    counts: dict[tuple[int, int], int] = {}
    for n, t in zip(sizes, steps, strict=True):
        for step, c in zip(*np.unique(t, return_counts=True), strict=True):
            counts[n, int(step)] = counts.get((n, int(step)), 0) + int(c)
    total = {n: sum(c for (m, _), c in counts.items() if m == n) for n in set(sizes)}
    seen = {n: sum(1 for (m, _) in counts if m == n) for n in set(sizes)}
    return [
        np.array([total[n] / (seen[n] * counts[n, int(step)]) for step in t], dtype=np.float32)
        for n, t in zip(sizes, steps, strict=True)
    ]


def training_states(
    sample: LabelledAssembly, states: StateSet | str
) -> tuple[np.ndarray, np.ndarray]:
    """(states, label masks) used for training on `sample`; see the module docstring."""
    chosen = _STATE_SETS[StateSet(states)](sample.truth)
    return chosen, state_masks(sample.truth, chosen)[0]


ALL_KNOWN = -1
"""The known-label mask of a state whose every part's label is known (all bits set)."""


def known_masks(sample: LabelledAssembly, states: np.ndarray) -> np.ndarray:
    """Per state, the parts whose label carries a loss (`LabelledAssembly.known`): all of them
    unless the label is partial, and there those the sample knows (none in a state it lacks)."""
    if sample.known is None:
        return np.full(len(states), ALL_KNOWN, dtype=np.int64)
    return np.array([sample.known.get(int(s), 0) for s in states], dtype=np.int64)


Item = tuple[AssemblyTensors, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""One chunk: (tensors, states, label masks, loss weights, feasible dead-end masks, known-label
masks)."""


class AssemblyBatchSampler(Sampler[list[int]]):
    """Shuffles chunks (whole assemblies or parts of big ones) and packs ≈`batch_size` states.

    Deliberately without `__len__`: the number of batches changes with each epoch's shuffle, and
    Lightning, given a length, takes the first epoch's count as every epoch's and validates only
    when a batch index hits it, so epochs with fewer batches would go unvalidated (early stopping,
    checkpoints and the lr schedule would then count validations, not epochs). Without a length,
    Lightning validates after the last batch of every epoch."""

    def __init__(self, chunk_sizes: Sequence[int], batch_size: int, shuffle: bool, seed: int):
        self.chunk_sizes = list(chunk_sizes)
        self.batch_size = batch_size
        self.shuffle = shuffle
        self.seed = seed
        self.epoch = 0

    def _batches(self) -> list[list[int]]:
        order = np.arange(len(self.chunk_sizes))
        if self.shuffle:
            order = np.random.default_rng([self.seed, self.epoch]).permutation(order)
        batches, current, count = [], [], 0
        for i in order.tolist():
            current.append(i)
            count += self.chunk_sizes[i]
            if count >= self.batch_size:
                batches.append(current)
                current, count = [], 0
        if current:
            batches.append(current)
        return batches

    def __iter__(self) -> Iterator[list[int]]:
        batches = self._batches()
        self.epoch += 1
        return iter(batches)


class StateDataset:
    """Chunks of (assembly, states, labels) with cached encodings; indexable by the sampler."""

    def __init__(
        self,
        samples: Sequence[LabelledAssembly],
        enc: GraphEncoding,
        states: StateSet | str,
        chunk_size: int,
        training: bool,
        seed: int,
        balance_steps: bool = False,
        dead_end_target: float = 0.0,
        dead_end_weight: float = 1.0,
    ) -> None:
        self.samples = list(samples)
        self.enc = enc
        self.training = training
        self.dead_end_target = dead_end_target
        self.dead_end_weight = dead_end_weight
        self.rng = np.random.default_rng([seed, int(training)])
        self.weighted = balance_steps or dead_end_weight != 1.0
        """Whether states carry loss weights other than 1 (batches then carry `weights`)."""
        self.partial = any(sample.known is not None for sample in self.samples)
        """Whether some labels are partial (batches then leave unknown parts out of `mask`)."""
        # (sample index, states, label masks, loss weights, feasible dead-end masks, known masks)
        self.chunks: list[tuple[int, *tuple[np.ndarray, ...]]] = []
        per_sample = [training_states(sample, states) for sample in self.samples]
        steps = step_weights(self.samples, [s for s, _ in per_sample]) if balance_steps else None
        for i, (s, y) in enumerate(per_sample):
            self._add(i, s, y, None if steps is None else steps[i], chunk_size)
        # Fixed encodings are computed once; randomised training encodings are redrawn per use.
        # Evaluation encodings stay fixed per assembly (seeded by its index) across epochs.
        self._fixed: dict[int, AssemblyTensors] = {}
        if not (enc.randomised and training):
            for i, sample in enumerate(self.samples):
                rng = np.random.default_rng([seed, i]) if enc.randomised else None
                self._fixed[i] = encode_assembly(sample.assembly, enc, training, rng)

    def _add(
        self, i: int, s: np.ndarray, y: np.ndarray, step: np.ndarray | None, chunk_size: int
    ) -> None:
        """Chunk sample `i`'s states with their labels, loss weights (step balancing weight, 1
        without, times `dead_end_weight` where no order completes), feasible dead-end masks and
        known-label masks, all fixed for the whole fit."""
        w = np.ones(len(s), dtype=np.float32) if step is None else step
        if self.dead_end_weight != 1.0:
            w = np.where(y == 0, np.float32(self.dead_end_weight), np.float32(1.0)) * w
        d = state_masks(self.samples[i].truth, s)[1]
        k = known_masks(self.samples[i], s)
        for lo in range(0, len(s), chunk_size):
            part = slice(lo, lo + chunk_size)
            self.chunks.append((i, s[part], y[part], w[part], d[part], k[part]))

    def extend(self, extra: Mapping[int, tuple[np.ndarray, np.ndarray]], chunk_size: int) -> None:
        """Add (states, label masks) for samples by index (the states a planner visited, see
        grace/cli/dagger_fit.py); they weigh 1 also under step balancing."""
        for i, (s, y) in extra.items():
            self._add(i, s, y, None, chunk_size)

    def __len__(self) -> int:
        return len(self.chunks)

    def __getitem__(self, k: int) -> Item:
        """(tensors, states, label masks, loss weights, feasible dead-end masks, known-label
        masks) of chunk `k`."""
        i, *rest = self.chunks[k]
        if i in self._fixed:
            return self._fixed[i], *rest
        return encode_assembly(self.samples[i].assembly, self.enc, True, self.rng), *rest

    def chunk_sizes(self) -> list[int]:
        return [len(s) for _, s, *_ in self.chunks]


def merge_chunks(dataset: StateDataset, collate: Collate, items: list[Item]) -> StateBatch:
    """One training batch from chunks of `dataset`: the collated states with their (graded)
    labels, loss weights and placeable masks, as the training loop and the benchmark see it;
    with partial labels, `mask` keeps only the parts whose label is known."""
    groups: dict[int, tuple[AssemblyTensors, list, list, list, list, list]] = {}
    for tensors, *parts in items:  # chunks of one assembly share its tensors: merge them
        group = groups.setdefault(id(tensors), (tensors, [], [], [], [], []))
        for into, part in zip(group[1:], parts, strict=True):
            into.append(part)
    tensors = [g[0] for g in groups.values()]
    states = [np.concatenate(g[1]) for g in groups.values()]
    labels = [np.concatenate(g[2]) for g in groups.values()]
    batch = collate(tensors, states, labels)
    if dataset.weighted:
        batch.weights = torch.from_numpy(
            np.concatenate([np.concatenate(g[3]) for g in groups.values()])
        )
    dead_ends = np.concatenate([np.concatenate(g[4]) for g in groups.values()])
    graded = state_flags(dead_ends, batch.labels.shape[1]) * batch.mask
    batch.placeable = batch.labels + graded
    if dataset.dead_end_target:
        batch.labels = batch.labels + dataset.dead_end_target * graded
    if dataset.partial:
        known = np.concatenate([np.concatenate(g[5]) for g in groups.values()])
        batch.mask = batch.mask & state_flags(known, batch.mask.shape[1], torch.bool)
    return batch


def make_loader(
    dataset: StateDataset, collate: Collate, batch_size: int, shuffle: bool, seed: int
) -> DataLoader:
    """A DataLoader over `dataset` batched by assembly; runs in the main process (seeded)."""
    sampler = AssemblyBatchSampler(dataset.chunk_sizes(), batch_size, shuffle, seed)
    return DataLoader(
        dataset,
        batch_sampler=sampler,
        collate_fn=partial(merge_chunks, dataset, collate),
        num_workers=0,
    )


class StateDataModule(pl.LightningDataModule):
    """Lightning DataModule serving per-state samples of the chosen train / val assemblies.

    Built from the `datamodule` config group with `_partial_`: the config gives the sampling
    settings, the caller the assemblies, the model's graph encoding and its collate function.
    """

    def __init__(
        self,
        train: Sequence[LabelledAssembly],
        val: Sequence[LabelledAssembly],
        enc: GraphEncoding,
        collate: Collate = collate_dense,
        states: StateSet = StateSet.reachable,
        batch_size: int = 256,
        seed: int = 0,
        mixing: Mixing = Mixing.assembly,
        balance_steps: bool = False,
        dead_end_target: float = 0.0,
        dead_end_weight: float = 1.0,
    ) -> None:
        super().__init__()
        if not 0.0 <= dead_end_target < 0.5:
            raise UserError(
                f"datamodule.dead_end_target={dead_end_target} must lie in [0, 0.5) (a dead-end "
                "part scored at λ 0.5 would be planned); fix: e.g. 0.25, or 0 for the paper's"
            )
        if dead_end_weight < 0.0:
            raise UserError(
                f"datamodule.dead_end_weight={dead_end_weight} is negative; fix: a loss weight "
                "≥ 0 (1 = every state weighs the same)"
            )
        self.collate, self.batch_size, self.seed = collate, batch_size, seed
        chunk = batch_size if Mixing(mixing) is Mixing.assembly else 1
        self.chunk_size = chunk
        self.train_set = StateDataset(
            train, enc, states, chunk, True, seed, balance_steps, dead_end_target, dead_end_weight
        )
        self.val_set = StateDataset(
            val, enc, states, batch_size, False, seed, dead_end_target=dead_end_target
        )
        self._start_epoch = 0
        self._sampler: AssemblyBatchSampler | None = None

    def train_dataloader(self) -> DataLoader:
        loader = make_loader(self.train_set, self.collate, self.batch_size, True, self.seed)
        self._sampler = loader.batch_sampler
        self._sampler.epoch = self._start_epoch
        return loader

    def state_dict(self) -> dict[str, Any]:
        """Saved in every checkpoint: the epochs shuffled so far and the generator of randomised
        training encodings, so a fit resumed from a checkpoint draws what an uninterrupted one
        would."""
        epoch = self._sampler.epoch if self._sampler is not None else self._start_epoch
        return {"epoch": epoch, "encoding_rng": self.train_set.rng.bit_generator.state}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self._start_epoch = int(state["epoch"])
        self.train_set.rng.bit_generator.state = state["encoding_rng"]

    def val_dataloader(self) -> DataLoader:
        return make_loader(self.val_set, self.collate, self.batch_size, False, self.seed)
