"""A node's NodeStatus as the ROS-standard DiagnosticStatus and back (drill_ros.diagnostics):
the level from the health and the errors new since the last report, the node's values
kept to 9 significant digits, the fixed keys out of the node's own values."""
import math

from diagnostic_msgs.msg import DiagnosticStatus
from drill_msgs.msg import NodeStatus

from drill_ros.diagnostics import HARDWARE_ID, diagnostic_array, status_fields


def node_status(healthy=True, error_count=0, last_error=""):
    m = NodeStatus(node="estimator", mode="fast", rate_hz=10.0, healthy=healthy,
                   last_error=last_error, error_count=error_count,
                   keys=["nis", "frame_time_s", "rejected_samples"],
                   values=[3.141592653589793, 0.00107, math.nan])
    m.header.stamp.sec, m.header.stamp.nanosec = 12, 500
    return m


def test_a_report_carries_the_status_under_the_node_name_and_stamp():
    array = diagnostic_array(node_status(), new_errors=0)
    [report] = array.status
    assert (array.header.stamp.sec, array.header.stamp.nanosec) == (12, 500)
    assert (report.name, report.hardware_id, report.message) == ("estimator", HARDWARE_ID, "ok")
    assert report.level == DiagnosticStatus.OK
    back = status_fields(report)
    assert (back["mode"], back["rate_hz"], back["healthy"], back["error_count"]) == \
        ("fast", 10.0, True, 0)
    assert back["last_error"] == "" and back["level"] == 0
    assert set(back["values"]) == {"nis", "frame_time_s", "rejected_samples"}
    assert math.isclose(back["values"]["nis"], 3.14159265, rel_tol=1e-9)
    assert back["values"]["frame_time_s"] == 0.00107
    assert math.isnan(back["values"]["rejected_samples"])


def test_the_level_warns_on_new_errors_and_fails_on_an_unhealthy_node():
    warned = diagnostic_array(node_status(error_count=3, last_error="bad sample"), 1).status[0]
    assert warned.level == DiagnosticStatus.WARN and warned.message == "bad sample"
    assert status_fields(warned)["last_error"] == "bad sample"
    old = diagnostic_array(node_status(error_count=3, last_error="bad sample"), 0).status[0]
    assert old.level == DiagnosticStatus.OK
    failed = diagnostic_array(node_status(healthy=False, error_count=4), 0).status[0]
    assert failed.level == DiagnosticStatus.ERROR and status_fields(failed)["level"] == 2
