"""The planner's scoring timing (`python -m grace.model.timing`) times what a backward search
expansion asks: every removal of one state, each call on the same batch."""

import numpy as np

from grace.model.timing import removal_ms


def test_removal_ms_times_every_removal_of_each_state():
    asked = []

    def scorer(assembly, states):
        asked.append(np.asarray(states).tolist())
        return np.zeros((len(states), 6))

    times = removal_ms(scorer, None, [6, 3], calls=4)
    assert list(times) == [6, 3] and all(ms >= 0 for ms in times.values())
    assert len(asked) == 2 * (4 + 1)  # a warm-up call and the timed ones, per state
    assert asked[0] == [0b111111 & ~(1 << p) for p in range(6)]
    assert asked[-1] == [0b110, 0b101, 0b011]
