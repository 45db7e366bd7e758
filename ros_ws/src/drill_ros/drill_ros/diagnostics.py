"""Node health in the ROS-standard form: each node's NodeStatus as a
diagnostic_msgs/DiagnosticStatus on /diagnostics (read by Foxglove's Diagnostics panel,
rqt_robot_monitor, the diagnostic aggregator and the console), and back.

The level: ERROR once the node is unhealthy (an error it could not recover from), WARN
when it counted an error or a rejected input since its last report, else OK. The message
is the last error (or "ok"); the key/values are the mode, the loop rate, the health, the
error count, then the node's own values (names with their SI units, as in NodeStatus).
"""
from __future__ import annotations

import math

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

HARDWARE_ID = "drill_rig"
FIXED_KEYS = ("mode", "rate_hz", "healthy", "error_count")


def level(healthy: bool, new_errors: int) -> bytes:
    """The DiagnosticStatus level of a node's report."""
    if not healthy:
        return DiagnosticStatus.ERROR
    return DiagnosticStatus.WARN if new_errors > 0 else DiagnosticStatus.OK


def diagnostic_array(status, new_errors: int) -> DiagnosticArray:
    """A NodeStatus as a one-status DiagnosticArray with the same stamp;
    ``new_errors``: errors counted since the node's previous report."""
    values = [("mode", status.mode), ("rate_hz", f"{status.rate_hz:.6g}"),
              ("healthy", "true" if status.healthy else "false"),
              ("error_count", str(status.error_count)),
              *((key, f"{value:.9g}") for key, value in zip(status.keys, status.values))]
    report = DiagnosticStatus(level=level(status.healthy, new_errors), name=status.node,
                              message=status.last_error or "ok", hardware_id=HARDWARE_ID,
                              values=[KeyValue(key=k, value=v) for k, v in values])
    return DiagnosticArray(header=status.header, status=[report])


def status_fields(report: DiagnosticStatus) -> dict:
    """A node's report as the console shows it: mode, rate_hz, healthy, last_error,
    error_count and its own values (floats; a value that is not a number is NaN)."""
    values = {kv.key: kv.value for kv in report.values}

    def number(text: str) -> float:
        try:
            return float(text)
        except ValueError:
            return math.nan
    return {"mode": values.get("mode", ""), "rate_hz": number(values.get("rate_hz", "nan")),
            "healthy": values.get("healthy") == "true",
            "last_error": "" if report.message == "ok" else report.message,
            "error_count": int(number(values.get("error_count", "0"))),
            "level": int.from_bytes(report.level, "little"),
            "values": {k: number(v) for k, v in values.items() if k not in FIXED_KEYS}}
