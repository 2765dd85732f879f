import itertools
import math

from grace.domain.orders import GroundTruth


def test_free_assembly_has_all_orders_and_naive_count():
    gt = GroundTruth.explore(4, lambda state, part: True)
    assert gt.feasible
    assert gt.n_orders() == math.factorial(4)
    assert len(list(gt.orders())) == 24
    assert gt.naive_checks == 4 * math.factorial(4)
    assert gt.checks == sum(4 - s.bit_count() for s in range(16) if s != 15)
    assert list(gt.dead_ends()) == []


def test_precedence_and_dead_end():
    # part 1 only after part 0; part 2 never after part 1 (it would be blocked)
    def can_place(state, part):
        if part == 1:
            return bool(state & 1)
        if part == 2:
            return not state & 2
        return True

    gt = GroundTruth.explore(3, can_place)
    assert sorted(gt.orders()) == sorted([(0, 2, 1), (2, 0, 1)])
    assert gt.label(0) == 0b101
    assert gt.label(0b001) == 0b100  # placing 1 now leads to the dead end
    assert list(gt.dead_ends()) == [(0, 1)]
    assert [o for o in itertools.permutations(range(3)) if gt.is_order(o)] == [(0, 2, 1), (2, 0, 1)]
    assert not gt.is_order((0, 2)) and not GroundTruth.from_orders(3, []).is_order((0, 2, 1))
    # the dead-end state 0b011 and the complete state are no decision states of the orders
    assert gt.order_states().tolist() == [0b000, 0b001, 0b100, 0b101]


def test_infeasible_and_from_orders_roundtrip():
    gt = GroundTruth.explore(2, lambda state, part: part == 0)
    assert not gt.feasible
    assert gt.n_orders() == 0
    assert list(gt.dead_ends()) == [(0,)]
    assert gt.order_states().tolist() == [0]  # infeasible: the empty state, all labels 0
    again = GroundTruth.from_orders(2, [], list(gt.dead_ends()))
    assert again == gt

    full = GroundTruth.explore(3, lambda s, p: p != 1 or s & 1)
    assert GroundTruth.from_orders(3, list(full.orders())).n_orders() == full.n_orders()
