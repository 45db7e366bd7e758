"""Which inputs open a new sample of a periodic advisor (NMPC, baseline, sequencer)."""
from __future__ import annotations


class SampleGate:
    """Admits one input per sample period and gives the scenario time of the sample.

    fast mode: only inputs stamped on the sample grid (t_k a multiple of the period), so a
    command is stamped t_k, as the actuators wait for it. realtime: the first input of each
    new period counted from the first input seen. Scenario time runs from that first input
    in both modes (fast-mode stamps start at 0; realtime stamps are wall-clock time).
    """

    def __init__(self, period_ns: int, fast: bool):
        self.period_ns = period_ns
        self.fast = fast
        self.start_ns: int | None = None
        self.last_sample: int | None = None

    def admit(self, stamp_ns: int) -> bool:
        """True if the input stamped ``stamp_ns`` starts a new sample."""
        if self.fast and stamp_ns % self.period_ns != 0:
            return False
        if self.start_ns is None:
            self.start_ns = stamp_ns
        sample = (stamp_ns - self.start_ns) // self.period_ns
        if self.last_sample is not None and sample <= self.last_sample:
            return False
        self.last_sample = sample
        return True

    def scenario_time_s(self, stamp_ns: int) -> float:
        """Seconds since the first admitted input (0 before any)."""
        return 0.0 if self.start_ns is None else (stamp_ns - self.start_ns) * 1e-9
