"""Equal network inputs of different labels (docs/information-ceiling.md): counted on hand-built
steps, with the Bayes ceiling a majority vote reaches."""

import copy

import numpy as np
import pytest

from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError
from grace.evaluation.input_conflicts import (
    InputKeys,
    Steps,
    add_counts,
    against_training,
    move_conflicts,
    moved,
    within,
)
from grace.graphs.datamodule import state_masks
from grace.graphs.encoding import GraphEncoding


def test_one_equal_input_of_another_label_is_one_conflict(samples):
    keys = InputKeys(GraphEncoding())
    sample = samples[1]
    train = keys.steps(sample, [0], [0b001])  # empty state: only part 0 is a valid first step
    twin = copy.deepcopy(sample)  # another object, the same tensors
    test = keys.steps(twin, [0], [0b011])  # here part 1 is valid too: one step disagrees
    counts = add_counts([against_training(train, test)])
    assert counts["steps"] == sample.size
    assert counts["seen_in_training"] == sample.size
    assert counts["label_conflicts"] == 1
    assert counts["ceiling_on_conflicts"] == 0.5  # one valid, one invalid: a coin flip
    assert counts["ceiling"] == (sample.size - 0.5) / sample.size
    both = add_counts([within(Steps.concat([train, test]))])
    assert both["shared_input"] == 2 * sample.size
    assert both["label_conflicts"] == 2 and both["ceiling_on_conflicts"] == 0.5


def test_distinct_inputs_never_conflict(samples):
    keys = InputKeys(GraphEncoding())
    first, other = samples[1], samples[2]
    train = keys.steps(first, [0], [0b001])
    test = keys.steps(other, [0], [0b011])
    counts = add_counts([against_training(train, test)])
    assert counts["seen_in_training"] == 0 and counts["label_conflicts"] == 0
    assert counts["ceiling"] == 1.0
    # the same assembly in two states: different flags, different inputs
    placed = keys.steps(first, [0b100], [0b011])
    assert add_counts([within(Steps.concat([train, placed]))])["label_conflicts"] == 0


def test_placed_parts_are_no_candidates(samples):
    sample = samples[1]
    steps = InputKeys(GraphEncoding()).steps(sample, [0b101], [0b010])
    assert len(steps) == sample.size - 2 and steps.label.sum() == 1


def test_a_randomised_encoding_is_refused():
    with pytest.raises(UserError, match=r"model\.graph"):
        InputKeys(GraphEncoding(pe="random"))


def test_a_move_keeps_the_input_and_counts_the_labels_it_changes(samples):
    keys = InputKeys(GraphEncoding())
    frame = samples[0]  # the bracket needs both profiles placed
    same = add_counts(
        [
            move_conflicts(
                keys, frame, lambda a: LabelledAssembly(a, frame.truth), [[50.0, 0.0]], "reachable"
            )
        ]
    )
    assert same["moved"] == same["same_input"] == 1 and same["label_changes"] == 0
    # elsewhere in the cell the bracket could go first: its steps change label, not their input
    loose = GroundTruth.explore(3, lambda state, part: True)
    changed = move_conflicts(
        keys, frame, lambda a: LabelledAssembly(a, loose), [[0.0, -50.0]], "reachable"
    )
    states = np.union1d(frame.truth.states[:-1], loose.states[:-1])
    before, after = state_masks(frame.truth, states)[0], state_masks(loose, states)[0]
    expected = int(np.bitwise_count((before ^ after) & ~states & 0b111).sum())
    assert changed["label_changes"] == expected > 0
    assert changed["feasibility_flips"] == 0  # both still complete
    assert moved(frame.assembly, 0.0, -50.0).parts[0].xy == (0.0, -50.0)
