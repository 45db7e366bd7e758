"""Recorder node: every (or a chosen set of) topic(s) to a rosbag2-compatible MCAP file.

Run: python -m drill_bag.recorder --ros-args -p output:=/path/run.mcap
"""
import re
import signal
import sys
import threading
import time
from functools import partial
from pathlib import Path
from collections.abc import Iterable, Sequence

import rclpy
from ament_index_python.packages import PackageNotFoundError
from drill_ros import topics
from drill_ros.budget import ProcessClock
from drill_ros.executors import create_executor
from drill_ros.node import RigNode
from drill_ros.runner import shut_down
from drill_ros.status import HealthPublisher
from drill_msgs.msg import NodeStatus
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from drill_bag import mcap_io
from drill_bag.mcap_io import TRUTH_METADATA, QosOffer

STATUS_TOPIC = topics.status("recorder")
DRAIN_QUIET_S = 0.2
DRAIN_MAX_S = 10.0
DRAIN_SPIN_S = 0.02
SPIN_TIMEOUT_S = 0.1


def wanted(topic: str, topics: Sequence[str], exclude_regex: str) -> bool:
    """Topic filter: the explicit list (empty = all) minus the exclude regex."""
    if topics and topic not in topics:
        return False
    return not (exclude_regex and re.search(exclude_regex, topic))


def offer_from_profile(profile: QoSProfile) -> QosOffer:
    """A discovered publisher's QoS profile as a plain QosOffer."""
    return QosOffer(
        history=int(profile.history), depth=int(profile.depth),
        reliability=int(profile.reliability), durability=int(profile.durability),
        deadline_ns=profile.deadline.nanoseconds, lifespan_ns=profile.lifespan.nanoseconds,
        liveliness=int(profile.liveliness),
        liveliness_lease_duration_ns=profile.liveliness_lease_duration.nanoseconds,
        avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions))


def subscription_qos(offers: Sequence[QosOffer]) -> QoSProfile:
    """Keep-all reader that matches every offer: reliable / transient local only if all are."""
    reliable = all(o.reliability == mcap_io.RELIABLE for o in offers)
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if mcap_io.is_latched(offers)
                    else DurabilityPolicy.VOLATILE))


def status_values(counts: dict[str, int]) -> tuple[list[str], list[float]]:
    """NodeStatus keys/values: per-topic message counts and their total."""
    keys = [f"messages{topic}" for topic in sorted(counts)] + ["messages_total"]
    values = [float(counts[topic]) for topic in sorted(counts)] + [float(sum(counts.values()))]
    return keys, values


class Recorder(RigNode):
    """Subscribes raw (CDR) to discovered topics and writes them with mcap_io.McapWriter."""

    def __init__(self, **kwargs):
        super().__init__("recorder", **kwargs)
        self.output = self.declare_parameter("output", "recording.mcap").value
        self.topic_list = list(
            self.declare_parameter("topics", Parameter.Type.STRING_ARRAY).value or [])
        self.exclude_regex = self.declare_parameter("exclude_regex", "").value
        chunk_size_bytes = self.declare_parameter(
            "chunk_size_bytes", mcap_io.DEFAULT_CHUNK_SIZE_BYTES).value
        compression = self.declare_parameter("compression", "zstd").value
        discovery_period_s = self.declare_parameter("discovery_period_s", 0.5).value
        status_period_s = self.declare_parameter("status_period_s", 1.0).value

        self._writer = mcap_io.McapWriter(self.output, chunk_size_bytes=chunk_size_bytes,
                                          compression=compression)
        truth_path = self.declare_parameter("truth", "").value
        if truth_path:          # the run's plant, as the plant was given it
            self._writer.add_metadata(TRUTH_METADATA, {"truth": Path(truth_path).read_text()})
        self._subscriptions_by_topic = {}
        self._unrecordable = set()
        self._status_pub = HealthPublisher(self, STATUS_TOPIC)
        self._errors: list[str] = []
        self._last_status = (time.monotonic(), 0)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(discovery_period_s, self.discover, clock=steady)
        self.create_timer(status_period_s, self.publish_status, clock=steady)
        self.discover()

    def discover(self) -> None:
        """Subscribe to every wanted topic that has a publisher and is not recorded yet."""
        for topic, types in self.get_topic_names_and_types():
            if (topic in self._subscriptions_by_topic or topic in self._unrecordable
                    or not wanted(topic, self.topic_list, self.exclude_regex)):
                continue
            infos = self.get_publishers_info_by_topic(topic)
            if infos:
                self._subscribe(topic, types[0], infos)

    def _subscribe(self, topic: str, type_name: str, infos: Iterable) -> None:
        infos = list(infos)
        offers = [offer_from_profile(i.qos_profile) for i in infos]
        try:
            msg_type = mcap_io.message_class(type_name)
            self._writer.add_topic(topic, type_name, offers, str(infos[0].topic_type_hash))
        except (ImportError, AttributeError, OSError, ValueError, PackageNotFoundError) as exc:
            self._errors.append(f"cannot record {topic} [{type_name}]: {exc}")
            self.get_logger().warning(self._errors[-1])
            self._unrecordable.add(topic)
            return
        self._subscriptions_by_topic[topic] = self.create_subscription(
            msg_type, topic, partial(self._on_message, topic), subscription_qos(offers),
            raw=True)
        self.get_logger().info(f"recording {topic} [{type_name}]")

    def _on_message(self, topic: str, data: bytes) -> None:
        if not self._writer.closed:
            self._writer.write(topic, data, self.get_clock().now().nanoseconds)

    @property
    def message_total(self) -> int:
        """Messages written so far, all topics."""
        return sum(self._writer.counts.values())

    def publish_status(self) -> None:
        """NodeStatus with per-topic counts; rate_hz = messages recorded per wall second."""
        counts = self._writer.counts
        total = sum(counts.values())
        now_s = time.monotonic()
        last_s, last_total = self._last_status
        self._last_status = (now_s, total)
        msg = NodeStatus(node="recorder", healthy=not self._writer.closed,
                         last_error=self._errors[-1] if self._errors else "",
                         error_count=len(self._errors))
        msg.header.stamp = self.get_clock().now().to_msg()
        use_sim_time = self.get_parameter("use_sim_time").value
        msg.mode = ("sim_time" if use_sim_time else "wall_time") + "/recording"
        msg.rate_hz = (total - last_total) / max(now_s - last_s, 1e-9)
        msg.keys, msg.values = status_values(counts)
        self._status_pub.publish(msg)

    def close(self) -> dict[str, int]:
        """Finish the MCAP file and write '<output>.counts.json'; idempotent."""
        if self._writer.closed:
            return self._writer.counts
        counts = self._writer.close()
        mcap_io.write_counts(self.output, counts)
        self.get_logger().info(f"closed {self.output}: {sum(counts.values())} messages")
        return counts


def spin_until(executor, stop: threading.Event, node: "Recorder") -> None:
    """Spin until stop is set or the context shuts down, then drain queued messages."""
    try:
        while not stop.is_set() and node.context.ok():
            executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
        drain(executor, node)
    except ExternalShutdownException:
        pass


def drain(executor, node: "Recorder") -> None:
    """Spin until no message arrived for DRAIN_QUIET_S (at most DRAIN_MAX_S)."""
    now_s = time.monotonic()
    deadline_s, quiet_since_s, last_total = now_s + DRAIN_MAX_S, now_s, node.message_total
    while node.context.ok() and now_s < deadline_s and now_s - quiet_since_s < DRAIN_QUIET_S:
        executor.spin_once(timeout_sec=DRAIN_SPIN_S)
        now_s = time.monotonic()
        if node.message_total != last_total:
            quiet_since_s, last_total = now_s, node.message_total


def main(args: list[str] | None = None) -> int:
    """Record until SIGINT/SIGTERM or rclpy shutdown; always leaves a finished file."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    clock = ProcessClock()
    node = Recorder()
    executor = create_executor()
    executor.add_node(node)
    clock.spinning()
    try:
        spin_until(executor, stop, node)
    finally:
        node.close()
        clock.write(node.get_name(), {node.get_name(): node.budget})
        shut_down(executor, node)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
