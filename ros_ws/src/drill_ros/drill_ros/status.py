"""Per-node status reporting on /<node>/status and /diagnostics (docs/design.md §2)."""
from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray
from drill_msgs.msg import NodeStatus

from drill_ros import topics
from drill_ros.diagnostics import diagnostic_array


class HealthPublisher:
    """A node's NodeStatus on its status topic and, the same report, on /diagnostics."""

    def __init__(self, node, topic: str):
        self._status = node.create_publisher(NodeStatus, topic, topics.RELIABLE)
        self._diagnostics = node.create_publisher(DiagnosticArray, topics.DIAGNOSTICS,
                                                  topics.RELIABLE)
        self._reported_errors = 0

    def publish(self, msg: NodeStatus) -> None:
        self._status.publish(msg)
        self._diagnostics.publish(diagnostic_array(msg, msg.error_count - self._reported_errors))
        self._reported_errors = msg.error_count


class StatusReporter:
    """Counts loop iterations and errors; publishes NodeStatus (and /diagnostics) once per
    second of node time."""

    def __init__(self, node, mode: str, period_s: float = 1.0, topic: str | None = None):
        self._node = node
        self.mode = mode
        # ``topic`` overrides /<node>/status (the nmpc node: /nmpc/status carries NmpcStatus)
        self._pub = HealthPublisher(node, topic or topics.status(node.get_name()))
        self._period_ns = int(period_s * 1e9)
        self._last_ns = None
        self._ticks = 0
        self.healthy = True
        self.last_error = ""
        self.error_count = 0
        self.values: dict[str, float] = {}

    def error(self, text: str, fatal: bool = False) -> None:
        """Record an error (or a rejected input); ``fatal`` marks the node unhealthy."""
        self.error_count += 1
        self.last_error = text
        if fatal:
            self.healthy = False
        self._node.get_logger().warning(text)

    def tick(self, now_ns: int) -> None:
        """Count one main-loop iteration at node time ``now_ns`` and publish when due."""
        self._ticks += 1
        if self._last_ns is None:
            self._last_ns = now_ns
            return
        elapsed = now_ns - self._last_ns
        if elapsed >= self._period_ns:
            self.publish(now_ns, self._ticks / (elapsed * 1e-9))
            self._last_ns, self._ticks = now_ns, 0

    def publish(self, now_ns: int, rate_hz: float = 0.0) -> None:
        msg = NodeStatus()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now_ns, 1_000_000_000)
        msg.node = self._node.get_name()
        msg.mode = self.mode
        msg.rate_hz = float(rate_hz)
        msg.healthy = self.healthy
        msg.last_error = self.last_error
        msg.error_count = self.error_count
        msg.keys = list(self.values)
        msg.values = [float(v) for v in self.values.values()]
        self._pub.publish(msg)
