"""The plant's side of the fast-mode lockstep (docs/architecture.md), shared by the
tripping plant and the drilling plant: start frame 0 once the graph the launcher lists
(``wait_for``) is connected, fail loudly when the frames stop advancing, and let the last
samples reach their readers before the plant's process ends."""
from __future__ import annotations

import time
from collections.abc import Callable

from rclpy.duration import Duration

from drill_ros import topics

START_POLL_S = 0.05
WAITING_LOG_S = 10.0      # how often the plant says what it still waits for before t_0
STALL_POLL_S = 1.0
FLUSH_TIMEOUT_S = 5.0


def flush(publishers, timeout_s: float = FLUSH_TIMEOUT_S) -> bool:
    """Wait until every reader has acknowledged what ``publishers`` sent (reliable QoS):
    a writer destroyed before that takes its unacknowledged samples with it, and the
    recorder, stopped last, would miss the run's last frames. False if a reader had not
    within ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    return all(p.wait_for_all_acked(Duration(seconds=max(0.0, deadline - time.monotonic())))
               for p in publishers)


def missing_endpoints(node, wait_for) -> list[str]:
    """The ``sub@topic:N`` / ``pub@topic:N`` (bare ``topic:N``: sub) of ``wait_for`` that
    have fewer than N subscriptions / publishers in the graph, each with the count seen."""
    out = []
    for spec in wait_for:
        if not spec:
            continue
        topic, _, count = spec.rpartition(":")
        kind, topic = topic.split("@", 1) if "@" in topic else ("sub", topic)
        counter = node.count_subscribers if kind == "sub" else node.count_publishers
        seen = counter(topic)
        if seen < int(count):
            out.append(f"{spec} (seen {seen})")
    return out


class LockstepStart:
    """Calls ``start`` once the graph has been connected for ``topics.MATCH_SETTLE_S``
    (DDS matches the endpoints some time after the graph shows them), then watches the
    frame counter ``frame``: if it stands still for ``stall_timeout_s`` of wall time,
    ``stalled`` is called once (the node reports what it misses and finishes)."""

    def __init__(self, node, wait_for, start: Callable[[], None], frame: Callable[[], int],
                 stall_timeout_s: float, stalled: Callable[[], None]):
        self._node, self._wait_for = node, wait_for
        self._start, self._frame = start, frame
        self._stall_timeout_s, self._stalled = stall_timeout_s, stalled
        self._ready_since: float | None = None
        self._progress: tuple[int, float] | None = None
        self._logged_at = time.monotonic()
        self._timer = node.create_timer(START_POLL_S, self._poll_graph)

    def _poll_graph(self) -> None:
        now = time.monotonic()
        missing = missing_endpoints(self._node, self._wait_for)
        if missing:
            self._ready_since = None
            if now - self._logged_at >= WAITING_LOG_S:
                self._logged_at = now
                self._node.get_logger().info(f"waiting for the graph: {', '.join(missing)}")
            return
        if self._ready_since is None:
            self._ready_since = now
        if now - self._ready_since >= topics.MATCH_SETTLE_S:
            self._timer.cancel()
            self._node.get_logger().info("graph connected; starting lockstep")
            self._progress = (self._frame(), now)
            self._timer = self._node.create_timer(STALL_POLL_S, self._check_stall)
            self._start()

    def _check_stall(self) -> None:
        now = time.monotonic()
        if self._frame() != self._progress[0]:
            self._progress = (self._frame(), now)
        elif now - self._progress[1] > self._stall_timeout_s:
            self._timer.cancel()
            self._stalled()
