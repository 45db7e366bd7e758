"""The Python API (drill_rig): a closed loop in process as a DataFrame whose figures agree
with its own columns (the BHP RMSE worked out here from the truth and the reference),
indexed by simulated time at the sensor rate; a recorded run's topic as a DataFrame on a
UTC time index; bad input a RunError that says why, never an exit."""
import math

import numpy as np
import pytest
from drill_msgs.msg import RigMeasurement
from rclpy.serialization import serialize_message

import drill_rig
from drill_bag import mcap_io
from drill_studies.loop_bench import TRACE

NS = 1_000_000_000


@pytest.fixture(scope="module")
def short_trip():
    return drill_rig.simulate("short_trip", controller="baseline", seed=3)


def test_simulate_gives_the_trace_at_the_sensor_rate(short_trip):
    f = short_trip
    assert f.index.name == "time_s" and list(f.columns) == [c for c in TRACE if c != "time_s"]
    assert len(f) == 900 and np.allclose(np.diff(f.index), 0.1)
    assert f.attrs["controller"] == "baseline" and f.attrs["scenario"] == "short_trip"
    rmse = math.sqrt(np.mean((f["bhp_pa"] - f["bhp_ref_pa"]) ** 2))
    assert math.isclose(f.attrs["summary"]["bhp_rmse_pa"], rmse, rel_tol=1e-12)
    assert 6.0e7 < f["bhp_pa"].min() and f["string_position_m"].max() > 5.0   # it tripped


def test_the_same_seed_gives_the_same_frame(short_trip):
    again = drill_rig.simulate("short_trip", controller="baseline", seed=3)
    assert again.equals(short_trip)


@pytest.mark.parametrize("kwargs, reason", [
    ({"scenario": "no_such_trip"}, "unknown scenario 'no_such_trip'; known: "),
    ({"scenario": "short_trip", "controller": "open_loop"}, "the in-process loop runs"),
    ({"scenario": "short_trip", "mismatch": "made_up"}, "mismatch: value 'made_up' is not"),
])
def test_bad_input_is_a_run_error_with_the_reason(kwargs, reason):
    with pytest.raises(drill_rig.RunError, match=reason):
        drill_rig.simulate(**kwargs)


def test_load_run_reads_a_topic_on_a_utc_index(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "summary.json").write_text('{"bhp_rmse_pa": 12.5}')
    with mcap_io.McapWriter(run / "run.mcap") as writer:
        writer.add_topic("/rig/measurement", "drill_msgs/msg/RigMeasurement")
        for k in range(3):
            m = RigMeasurement(bhp_pa=6.85e7 + k, string_flow_valid=True)
            m.header.stamp.sec, m.header.stamp.nanosec = divmod(k * NS // 10, NS)
            writer.write("/rig/measurement", serialize_message(m), k * NS // 10 + 5)
    f = drill_rig.load_run(run)
    assert str(f.index.tz) == "UTC" and f.index.name == "time_utc"
    assert [t.value for t in f.index] == [0, NS // 10, 2 * NS // 10]
    assert f["bhp_pa"].tolist() == [6.85e7, 6.85e7 + 1, 6.85e7 + 2]
    assert f.attrs["summary"] == {"bhp_rmse_pa": 12.5}
    with pytest.raises(drill_rig.RunError, match="not recorded"):
        drill_rig.load_run(run, "/rig/nothing")
    with pytest.raises(drill_rig.RunError, match="no such directory"):
        drill_rig.load_run(tmp_path / "missing")
