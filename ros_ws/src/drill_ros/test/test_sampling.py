"""SampleGate: one input per period; scenario time from the first admitted input."""
from drill_ros.sampling import SampleGate

SECOND_NS = 1_000_000_000
FRAME_NS = 100_000_000


def test_fast_mode_admits_only_grid_stamps_once():
    gate = SampleGate(SECOND_NS, fast=True)
    admitted = [k * FRAME_NS for k in range(25) if gate.admit(k * FRAME_NS)]
    assert admitted == [0, SECOND_NS, 2 * SECOND_NS]
    assert not gate.admit(2 * SECOND_NS)                    # a repeated stamp
    assert gate.scenario_time_s(2 * SECOND_NS) == 2.0


def test_realtime_counts_periods_from_the_first_input():
    wall0 = 1_795_000_000 * SECOND_NS + 37_000_000          # wall-clock stamps, off the grid
    gate = SampleGate(SECOND_NS, fast=False)
    assert gate.scenario_time_s(wall0) == 0.0
    stamps = [wall0 + k * 95_000_000 for k in range(25)]    # jittery 95 ms frames
    admitted = [s for s in stamps if gate.admit(s)]
    assert [round(gate.scenario_time_s(s), 3) for s in admitted] == [0.0, 1.045, 2.09]
