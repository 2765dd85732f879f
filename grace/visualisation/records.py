"""What an experiment's recording holds (`task.recording`, docs/recordings.md).

The recorded plans are gathered where the policy and the simulator live
(grace/planning/plan_views.py); grace/visualisation/recording.py draws them.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class RecordingSettings:
    """Schema of `task.recording` (what an experiment's `sequences.rrd` holds)."""

    per_size: int = 2  # test assemblies recorded per test size and fold (0: no recording)
    top_k: int = 3  # predicted sequences listed per assembly, best first
    truth_orders: int = 5  # ground-truth orders listed per assembly
