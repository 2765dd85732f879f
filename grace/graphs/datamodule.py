"""Per-state training samples of labelled assemblies, batched by assembly (SPEC §5, issue 3).

A sample is one state of one assembly with its next-step labels (the `completable` mask: a part
is a valid next step iff placing it still allows completion). `states="orders"` (default) takes
the decision states of the ground-truth orders, the same states the step AUC tests
(`GroundTruth.order_states`): each infeasible assembly contributes its empty state with all-zero
labels, which is what lets "no complete sequence found" predict infeasibility. `states="reachable"`
adds every state the placement checks reach, dead ends included (all labels 0 there), which asks
the network to look ahead. The final state (all parts placed) is no decision and is left out.

With `mixing="assembly"` (default) batches hold about `batch_size` states drawn from whole
assemblies (large ones split into chunks), so that the fast path computes each surface embedding
once per batch. `mixing="state"` draws states independently, as the reference's shuffled
per-state data set does; batches then span many assemblies (states of one assembly still share
its embedding within a batch). The collate step
builds what the chosen network path consumes: per-state PyG graphs ("pyg") or padded per-assembly
tensors ("fast").
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import lightning.pytorch as pl
import numpy as np
import torch
from torch.utils.data import DataLoader, Sampler
from torch_geometric.data import Batch

from grace.domain.assembly import full_mask
from grace.domain.sample import LabelledAssembly
from grace.graphs.assembly_graph import AssemblyTensors, encode_assembly, state_flags, state_graph
from grace.graphs.dense import DenseAssemblies
from grace.graphs.encoding import GraphEncoding

STATE_SETS = ("orders", "reachable")
MIXINGS = ("assembly", "state")
IMPLS = ("fast", "pyg")


def training_states(sample: LabelledAssembly, states: str) -> tuple[np.ndarray, np.ndarray]:
    """(states, label masks) used for training on `sample`; see the module docstring."""
    if states not in STATE_SETS:
        raise ValueError(f"trainer.datamodule.states={states!r}: use one of {STATE_SETS}")
    truth = sample.truth
    if states == "orders":
        chosen = truth.order_states()
        return chosen, truth.completable[np.searchsorted(truth.states, chosen)]
    keep = truth.states != full_mask(truth.n_parts)
    return truth.states[keep], truth.completable[keep]


@dataclass
class StateBatch:
    """T states of A assemblies; `inputs` is a PyG Batch or DenseAssemblies, per path."""

    inputs: object
    state_assembly: torch.Tensor  # (T,) index into the batch's assemblies
    flags: torch.Tensor  # (T, N) assembled flags, 0 on padding
    labels: torch.Tensor  # (T, N) next-step labels, 0 on padding
    mask: torch.Tensor  # (T, N) bool: real part nodes

    @property
    def n_states(self) -> int:
        return self.flags.shape[0]


def collate_states(
    tensors: Sequence[AssemblyTensors],
    states: Sequence[np.ndarray],
    labels: Sequence[np.ndarray],
    impl: str,
) -> StateBatch:
    """Build one batch from per-assembly tensors and their state / label bitmasks."""
    if impl not in IMPLS:
        raise ValueError(f"model.impl={impl!r}: use one of {IMPLS}")
    n = max(t.n_parts for t in tensors)
    all_states = np.concatenate(states)
    state_assembly = torch.cat(
        [torch.full((len(s),), i, dtype=torch.long) for i, s in enumerate(states)]
    )
    sizes = torch.tensor([t.n_parts for t in tensors])[state_assembly]
    mask = torch.arange(n).unsqueeze(0) < sizes.unsqueeze(1)
    flags = state_flags(all_states, n) * mask
    y = state_flags(np.concatenate(labels), n) * mask
    if impl == "fast":
        inputs: object = DenseAssemblies.stack(list(tensors))
    else:
        pairs = zip(state_assembly.tolist(), all_states.tolist(), strict=True)
        inputs = Batch.from_data_list([state_graph(tensors[a], s) for a, s in pairs])
    return StateBatch(inputs, state_assembly, flags, y, mask)


class AssemblyBatchSampler(Sampler[list[int]]):
    """Shuffles chunks (whole assemblies or parts of big ones) and packs ≈`batch_size` states."""

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

    def __len__(self) -> int:
        return len(self._batches())


class StateDataset:
    """Chunks of (assembly, states, labels) with cached encodings; indexable by the sampler."""

    def __init__(
        self,
        samples: Sequence[LabelledAssembly],
        enc: GraphEncoding,
        states: str,
        chunk_size: int,
        training: bool,
        seed: int,
    ) -> None:
        self.samples = list(samples)
        self.enc = enc
        self.training = training
        self.rng = np.random.default_rng([seed, int(training)])
        self.chunks: list[tuple[int, np.ndarray, np.ndarray]] = []
        for i, sample in enumerate(self.samples):
            s, y = training_states(sample, states)
            for lo in range(0, len(s), chunk_size):
                self.chunks.append((i, s[lo : lo + chunk_size], y[lo : lo + chunk_size]))
        # Fixed encodings are computed once; randomised training encodings are redrawn per use.
        # Evaluation encodings stay fixed per assembly (seeded by its index) across epochs.
        self._fixed: dict[int, AssemblyTensors] = {}
        if not (enc.randomised and training):
            for i, sample in enumerate(self.samples):
                rng = np.random.default_rng([seed, i]) if enc.randomised else None
                self._fixed[i] = encode_assembly(sample.assembly, enc, training, rng)

    def __len__(self) -> int:
        return len(self.chunks)

    def __getitem__(self, k: int) -> tuple[AssemblyTensors, np.ndarray, np.ndarray]:
        i, s, y = self.chunks[k]
        if i in self._fixed:
            return self._fixed[i], s, y
        return encode_assembly(self.samples[i].assembly, self.enc, True, self.rng), s, y

    def chunk_sizes(self) -> list[int]:
        return [len(s) for _, s, _ in self.chunks]


def make_loader(
    dataset: StateDataset, impl: str, batch_size: int, shuffle: bool, seed: int
) -> DataLoader:
    """A DataLoader over `dataset` batched by assembly; runs in the main process (seeded)."""
    sampler = AssemblyBatchSampler(dataset.chunk_sizes(), batch_size, shuffle, seed)

    def collate(items: list[tuple[AssemblyTensors, np.ndarray, np.ndarray]]) -> StateBatch:
        groups: dict[int, tuple[AssemblyTensors, list[np.ndarray], list[np.ndarray]]] = {}
        for tensors, s, y in items:  # chunks of one assembly share its tensors: merge them
            group = groups.setdefault(id(tensors), (tensors, [], []))
            group[1].append(s)
            group[2].append(y)
        tensors = [g[0] for g in groups.values()]
        states = [np.concatenate(g[1]) for g in groups.values()]
        labels = [np.concatenate(g[2]) for g in groups.values()]
        return collate_states(tensors, states, labels, impl)

    return DataLoader(dataset, batch_sampler=sampler, collate_fn=collate, num_workers=0)


class StateDataModule(pl.LightningDataModule):
    """Lightning DataModule serving per-state samples of the chosen train / val assemblies."""

    def __init__(
        self,
        train: Sequence[LabelledAssembly],
        val: Sequence[LabelledAssembly],
        enc: GraphEncoding,
        impl: str = "fast",
        states: str = "reachable",
        batch_size: int = 256,
        seed: int = 0,
        mixing: str = "assembly",
    ) -> None:
        super().__init__()
        if mixing not in MIXINGS:
            raise ValueError(f"trainer.datamodule.mixing={mixing!r}: use one of {MIXINGS}")
        self.impl, self.batch_size, self.seed = impl, batch_size, seed
        chunk = batch_size if mixing == "assembly" else 1
        self.train_set = StateDataset(train, enc, states, chunk, True, seed)
        self.val_set = StateDataset(val, enc, states, batch_size, False, seed)

    def train_dataloader(self) -> DataLoader:
        return make_loader(self.train_set, self.impl, self.batch_size, True, self.seed)

    def val_dataloader(self) -> DataLoader:
        return make_loader(self.val_set, self.impl, self.batch_size, False, self.seed)
