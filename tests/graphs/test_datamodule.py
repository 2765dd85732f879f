import lightning.pytorch as pl
import numpy as np
import pytest
import torch
from hydra.errors import ConfigCompositionException, InstantiationException
from hydra.utils import instantiate
from torch.utils.data import DataLoader

from grace.domain.assembly import full_mask
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.graphs.batches import collate_dense, collate_graphs
from grace.graphs.datamodule import (
    AssemblyBatchSampler,
    StateDataModule,
    state_masks,
    step_weights,
    training_states,
)
from grace.graphs.dense import DenseAssemblies
from grace.graphs.encoding import GraphEncoding
from grace.model.module import step_auc

pytestmark = pytest.mark.numerics  # asserts on float results of torch arithmetic (.ci/kernels)

CONFIG_ERRORS = (ConfigCompositionException, InstantiationException)
"""A bad value fails at composition (a type) or at instantiation (a range)."""


@pytest.fixture
def samples(fake_simulator):
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(1)
    return [simulator.sample(n, rng) for n in (3, 4, 5, 6, 5, 4, 6, 6)]


def test_state_sets(samples):
    infeasible = [s for s in samples if not s.truth.feasible]
    feasible = [s for s in samples if s.truth.feasible]
    assert infeasible and feasible
    for sample in samples:
        states, labels = training_states(sample, "reachable")
        assert full_mask(sample.size) not in states.tolist()
        assert len(states) == len(sample.truth.states) - int(sample.truth.feasible)
        on_orders, order_labels = training_states(sample, "orders")
        assert set(on_orders) <= set(states)
        assert order_labels.tolist() == [sample.truth.label(int(s)) for s in on_orders]
        if sample.truth.feasible:
            assert np.all(order_labels != 0)
    # infeasible assemblies contribute states with zero labels: all reachable ones, or the empty
    states, labels = training_states(infeasible[0], "reachable")
    assert len(states) > 0 and not labels.any()
    states, labels = training_states(infeasible[0], "orders")
    assert states.tolist() == [0] and labels.tolist() == [0]
    with pytest.raises(ValueError, match="'all' is not a valid StateSet"):
        training_states(samples[0], "all")


def test_the_config_checks_sampling_options(cfg_factory):
    for key, value in (("states", "all"), ("mixing", "random"), ("batch_size", "many")):
        with pytest.raises(CONFIG_ERRORS, match=rf"datamodule\.{key}"):
            cfg_factory(f"datamodule.{key}={value}")


def test_sampler_packs_every_chunk_once_and_reshuffles():
    sizes = [5, 100, 30, 256, 7, 80, 120]
    sampler = AssemblyBatchSampler(sizes, 128, shuffle=True, seed=0)
    first, second = list(sampler), list(sampler)
    for batches in (first, second):
        assert sorted(i for b in batches for i in b) == list(range(len(sizes)))
        assert all(sum(sizes[i] for i in b[:-1]) < 128 for b in batches)
    assert first != second


class _ValidationProbe(pl.LightningModule):
    """The smallest module Lightning trains: records, per epoch, how many batches it had trained
    on when it was validated, and how many the epoch had."""

    def __init__(self) -> None:
        super().__init__()
        self.w = torch.nn.Parameter(torch.zeros(1))
        self.batches = 0
        self.validated_after: list[tuple[int, int]] = []
        self.epoch_batches: list[tuple[int, int]] = []

    def training_step(self, batch: torch.Tensor, _: int) -> torch.Tensor:
        self.batches += 1
        return (self.w - batch.float().mean()).pow(2).sum()

    def validation_step(self, batch: torch.Tensor, _: int) -> None:
        self.log("val_loss", (self.w - batch.float().mean()).pow(2).sum())

    def on_validation_epoch_end(self) -> None:
        self.validated_after.append((self.current_epoch, self.batches))

    def on_train_epoch_end(self) -> None:
        self.epoch_batches.append((self.current_epoch, self.batches))
        self.batches = 0

    def configure_optimizers(self) -> torch.optim.Optimizer:
        return torch.optim.SGD(self.parameters(), lr=0.01)


def test_every_epoch_is_validated_after_its_last_batch_although_batch_counts_vary(tmp_path):
    sizes = [5, 100, 30, 256, 7, 80, 120, 60, 90, 3, 200, 40]
    sampler = AssemblyBatchSampler(sizes, 128, shuffle=True, seed=1)
    counts = [len(list(sampler)) for _ in range(8)]
    assert min(counts[1:]) < counts[0] < max(counts[1:])  # shorter and longer epochs than the first

    def loader(shuffle: bool) -> DataLoader:
        sampler = AssemblyBatchSampler(sizes, 128, shuffle=shuffle, seed=1)
        return DataLoader(range(len(sizes)), batch_sampler=sampler, collate_fn=torch.tensor)

    probe = _ValidationProbe()
    trainer = pl.Trainer(
        max_epochs=8,
        accelerator="cpu",
        logger=False,
        enable_checkpointing=False,
        enable_progress_bar=False,
        enable_model_summary=False,
        num_sanity_val_steps=0,
        default_root_dir=tmp_path,
    )
    trainer.fit(probe, loader(True), loader(False))
    assert probe.epoch_batches == list(enumerate(counts))
    assert probe.validated_after == probe.epoch_batches


@pytest.mark.parametrize("collate", [collate_dense, collate_graphs])
def test_loaders_cover_all_states_with_padding_masks(samples, collate):
    dm = StateDataModule(samples[:5], samples[5:], GraphEncoding(), collate, batch_size=16)
    total = 0
    for batch in dm.train_dataloader():
        total += batch.n_states
        sizes = batch.mask.sum(dim=1)
        assert torch.all(batch.flags[~batch.mask] == 0) and torch.all(
            batch.labels[~batch.mask] == 0
        )
        assert torch.all(batch.flags.sum(dim=1) < sizes)  # the full state is never a sample
        if collate is collate_dense:
            assert isinstance(batch.inputs, DenseAssemblies)
        else:
            assert batch.inputs["part"].num_nodes == int(sizes.sum())
    assert total == sum(len(training_states(s, "reachable")[0]) for s in samples[:5])


def test_state_mixing_draws_states_across_assemblies(samples):
    dm = StateDataModule(samples, [], GraphEncoding(), batch_size=8, mixing="state")
    batches = list(dm.train_dataloader())
    assert sum(b.n_states for b in batches) == sum(
        len(training_states(s, "reachable")[0]) for s in samples
    )
    assert max(len(b.inputs.part_mask) for b in batches) > 2  # several assemblies per batch


def test_step_balancing_gives_every_step_of_a_size_the_same_weight(samples):
    states = [training_states(s, "reachable")[0] for s in samples]
    weights = step_weights(samples, states)
    for size in {s.size for s in samples}:
        picked = [i for i, s in enumerate(samples) if s.size == size]
        steps = np.concatenate([[bin(int(x)).count("1") for x in states[i]] for i in picked])
        w = np.concatenate([weights[i] for i in picked])
        assert np.isclose(w.mean(), 1.0)
        totals = [w[steps == t].sum() for t in np.unique(steps)]
        assert np.allclose(totals, len(w) / len(totals))
        empty = [weights[i][list(states[i]).index(0)] for i in picked]
        assert min(empty) > 1.0  # one empty state per assembly: the rarest step weighs most


def test_balanced_loader_carries_weights_and_validation_does_not(samples):
    dm = StateDataModule(
        samples[:5], samples[5:], GraphEncoding(), batch_size=16, balance_steps=True
    )
    train = list(dm.train_dataloader())
    assert all(b.weights is not None and len(b.weights) == b.n_states for b in train)
    weights = torch.cat([b.weights for b in train])
    assert np.isclose(float(weights.sum()), len(weights), rtol=1e-4)  # mean 1 per size
    assert float(weights.max()) > 1.0 > float(weights.min())
    assert all(b.weights is None for b in dm.val_dataloader())


def test_state_masks_are_the_ground_truths_and_empty_off_it(samples):
    truth = next(s.truth for s in samples if s.truth.feasible)
    valid, dead = state_masks(truth, truth.states)
    assert valid.tolist() == truth.completable.tolist()
    assert (dead == truth.placeable & ~truth.completable).tolist()
    assert not np.any(valid & dead)
    unknown = np.setdiff1d(np.arange(1 << truth.n_parts), truth.states)
    assert unknown.size and not state_masks(truth, unknown)[0].any()
    assert not state_masks(truth, unknown)[1].any()


def test_dead_end_target_grades_feasible_dead_end_parts_only(samples):
    kw = {"batch_size": 4096, "states": "reachable"}
    graded = StateDataModule(samples, samples, GraphEncoding(), dead_end_target=0.25, **kw)
    plain = StateDataModule(samples, samples, GraphEncoding(), **kw)
    for loader in ("train_dataloader", "val_dataloader"):
        batch = next(iter(getattr(graded, loader)()))
        base = next(iter(getattr(plain, loader)()))
        assert torch.equal(batch.flags, base.flags)
        assert set(batch.labels.unique().tolist()) == {0.0, 0.25, 1.0}
        assert torch.equal(batch.labels == 1, base.labels == 1)  # valid parts unchanged
    # every 0.25 is a feasible placement into a dead end, by the ground truth of its state
    # (validation keeps the assemblies' order, so the batch's assembly index is the sample's)
    batch = next(iter(graded.val_dataloader()))
    bits = 1 << torch.arange(batch.flags.shape[1])
    states = (batch.flags.long() * bits).sum(dim=1)
    checked = 0
    for row in range(batch.n_states):
        truth = samples[int(batch.state_assembly[row])].truth
        k = int(np.searchsorted(truth.states, int(states[row])))
        for part in range(truth.n_parts):
            bit = 1 << part
            dead_end = truth.placeable[k] & bit and not truth.completable[k] & bit
            expected = 1.0 if truth.completable[k] & bit else 0.25 if dead_end else 0.0
            assert float(batch.labels[row, part]) == expected
            checked += 1
    assert checked > 100


def test_step_auc_counts_only_valid_parts_as_positive():
    scores = torch.tensor([0.9, 0.3, 0.2, 0.1])
    assert float(step_auc(scores, torch.tensor([1.0, 0.25, 0.25, 0.0]))) == pytest.approx(1.0)
    assert step_auc(scores, torch.tensor([0.0, 0.25, 0.25, 0.0])) is None


@pytest.mark.parametrize("target", [-0.1, 0.5, 0.9])
def test_dead_end_target_at_or_above_the_threshold_is_refused(samples, target):
    with pytest.raises(UserError, match=r"datamodule\.dead_end_target.*fix"):
        StateDataModule(samples, [], GraphEncoding(), dead_end_target=target)


def test_dead_end_weight_scales_states_that_complete_nothing_in_training_only(samples):
    dm = StateDataModule(
        samples, samples, GraphEncoding(), batch_size=4096, states="reachable", dead_end_weight=0.3
    )
    batch = next(iter(dm.train_dataloader()))
    dead = batch.labels.sum(dim=1) == 0
    assert dead.any() and (~dead).any()
    assert torch.allclose(batch.weights[dead], torch.tensor(0.3))
    assert torch.all(batch.weights[~dead] == 1.0)
    assert all(b.weights is None for b in dm.val_dataloader())
    with pytest.raises(UserError, match=r"datamodule\.dead_end_weight"):
        StateDataModule(samples, [], GraphEncoding(), dead_end_weight=-1.0)


def test_batches_carry_the_ground_truths_placeable_parts_whatever_the_labels(samples):
    """The placeable mask (the second output's target, grace_pyg.NetConfig.placeable_head) is
    every physically feasible placement, dead ends included, under graded and paper labels."""
    for target in (0.0, 0.4):
        dm = StateDataModule(
            samples,
            samples,
            GraphEncoding(),
            batch_size=4096,
            states="reachable",
            dead_end_target=target,
        )
        batch = next(iter(dm.val_dataloader()))
        bits = 1 << torch.arange(batch.flags.shape[1])
        states = (batch.flags.long() * bits).sum(dim=1).numpy()
        for row in range(batch.n_states):
            truth = samples[int(batch.state_assembly[row])].truth
            k = int(np.searchsorted(truth.states, states[row]))
            expected = (truth.placeable[k] >> np.arange(truth.n_parts)) & 1
            assert batch.placeable[row, : truth.n_parts].tolist() == expected.tolist()
        assert torch.all(batch.placeable[~batch.mask] == 0)
        assert torch.all(batch.placeable >= (batch.labels == 1).float())


def test_a_partial_label_leaves_its_unknown_parts_out_of_the_loss_mask(samples):
    """Parts a partial label does not know (`LabelledAssembly.known`) are out of `mask`, so no
    loss reads their targets; every part of the other samples stays in."""
    partial = next(s for s in samples if s.truth.feasible and s.size >= 5)
    others = [s for s in samples if s is not partial]
    states = training_states(partial, "orders")[0]
    known = {int(s): int(s) | 0b1 for s in states}  # placed parts and part 0 only
    masked = LabelledAssembly(partial.assembly, partial.truth, partial.info, known)
    kw = {"batch_size": 4096, "states": "orders"}
    batch = next(
        iter(StateDataModule([], [masked, *others], GraphEncoding(), **kw).val_dataloader())
    )
    plain = next(
        iter(StateDataModule([], [partial, *others], GraphEncoding(), **kw).val_dataloader())
    )
    assert torch.equal(batch.labels, plain.labels) and torch.equal(batch.flags, plain.flags)
    ours = batch.state_assembly == 0  # validation keeps the samples' order
    assert torch.equal(batch.mask[~ours], plain.mask[~ours])
    bits = 1 << torch.arange(batch.flags.shape[1])
    for row in torch.nonzero(ours).flatten().tolist():
        state = int((batch.flags[row].long() * bits).sum())
        kept = batch.mask[row].nonzero().flatten().tolist()
        assert kept == [p for p in range(partial.size) if known[state] >> p & 1]
    assert int(ours.sum()) == len(states) and batch.mask[ours].sum() < plain.mask[ours].sum()
