"""A multi-stand trip's run ends its settle time after the rig floor first reports the trip
done, never after the scenario's duration, and not early without a settle time."""
import pytest

from drill_core.config import ConfigError
from drill_core.schema import build
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.run_end import RunEnd
from drill_core.tripping.sequence import DONE, MOVING, PUMP_UP

FRAME_S = 0.1


def test_the_run_ends_its_settle_time_after_the_first_done_frame():
    end = RunEnd(2900.0, FRAME_S, TripProgramme(direction="out", stands=10, settle_s=60.0))
    assert end.last_k == 29000
    for k, phase in ((100, MOVING), (24000, PUMP_UP), (24110, DONE), (24111, DONE)):
        end.floor_frame(k, phase)
    assert (end.done_k, end.last_k) == (24110, 24710)
    assert end.end_s == pytest.approx(2471.0)


def test_the_duration_caps_the_run_and_no_settle_time_keeps_it():
    late = RunEnd(100.0, FRAME_S, TripProgramme(direction="in", stands=1, settle_s=60.0))
    late.floor_frame(900, DONE)
    assert late.last_k == 1000
    unset = RunEnd(100.0, FRAME_S, TripProgramme(direction="in", stands=1))
    unset.floor_frame(10, DONE)
    assert (unset.done_k, unset.last_k) == (10, 1000)
    assert RunEnd(100.0, FRAME_S, None).last_k == 1000


def test_a_settle_time_under_a_frame_still_leaves_the_estimator_its_sample():
    """The estimator reads the floor's frame t_k with the measurement t_{k+1}."""
    end = RunEnd(100.0, FRAME_S, TripProgramme(direction="out", stands=1, settle_s=0.1))
    end.floor_frame(500, DONE)
    assert end.last_k == 501


def test_a_settle_time_out_of_range_names_its_key():
    with pytest.raises(ConfigError, match=r"trip\.settle_s.*\[0\.1, 3600\] s"):
        build(TripProgramme, {"direction": "out", "stands": 1, "settle_s": 0.0}, "trip.yaml",
              "trip")
