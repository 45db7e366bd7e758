"""Realtime frame lateness against the timer's schedule (drill_plant.frame_lateness)."""
import pytest

from drill_plant.frame_lateness import FrameLateness


def test_lateness_is_measured_against_the_schedule_of_the_first_frame():
    late = FrameLateness(0.1)
    assert late.values() == {"frame_late_p99_s": 0.0, "frame_late_max_s": 0.0,
                             "frames_skipped": 0.0}
    starts = [100.0, 100.1, 100.23, 100.3, 100.4]   # frame 2 starts 30 ms late; no drift after
    got = [late.tick(t) for t in starts]
    assert got == pytest.approx([0.0, 0.0, 0.03, 0.0, 0.0], abs=1e-9)
    assert late.values()["frame_late_max_s"] == pytest.approx(0.03)
    assert late.values()["frames_skipped"] == 0.0


def test_an_early_frame_counts_as_on_time():
    late = FrameLateness(0.1)
    late.tick(5.0)
    assert late.tick(5.09) == 0.0
    assert late.tick(5.2) == 0.0 and late.values()["frames_skipped"] == 0.0


def test_a_stall_skips_the_periods_it_missed_and_the_frames_after_it_are_on_time():
    """A 0.4 s stall: the timer fires once, 0.43 s after its last frame (the periods due at
    100.2, 100.3 and 100.4 s passed over), then on its schedule again. Against a grid
    that counted every frame, each frame after it would read 0.3 s late."""
    late = FrameLateness(0.1)
    starts = [100.0, 100.1, 100.53, 100.6, 100.7, 100.8]
    got = [late.tick(t) for t in starts]
    assert got == pytest.approx([0.0, 0.0, 0.03, 0.0, 0.0, 0.0], abs=1e-9)
    assert late.values()["frames_skipped"] == 3.0
