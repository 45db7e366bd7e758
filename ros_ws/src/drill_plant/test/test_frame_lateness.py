"""Realtime frame lateness against the wall clock (drill_plant.frame_lateness)."""
import pytest

from drill_plant.frame_lateness import FrameLateness


def test_lateness_is_measured_against_the_grid_of_the_first_frame():
    late = FrameLateness(0.1)
    assert late.values() == {"frame_late_p99_s": 0.0, "frame_late_max_s": 0.0}
    starts = [100.0, 100.1, 100.23, 100.3, 100.4]   # frame 2 starts 30 ms late; no drift after
    got = [late.tick(t) for t in starts]
    assert got == pytest.approx([0.0, 0.0, 0.03, 0.0, 0.0], abs=1e-9)
    assert late.values()["frame_late_max_s"] == pytest.approx(0.03)


def test_an_early_frame_counts_as_on_time():
    late = FrameLateness(0.1)
    late.tick(5.0)
    assert late.tick(5.09) == 0.0
