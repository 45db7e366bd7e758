"""Foxglove bridge node: streams every topic of a live run to Foxglove (``rig run ...
--foxglove [PORT]``; docs/gateways.md).

    python -m drill_gateway.foxglove_node --ros-args -p port:=8765

Parameters: ``port`` (8765; 0 picks a free one), ``host`` (127.0.0.1: this machine only),
``discovery_period_s`` (0.5). Like the recorder it discovers the topics that have a
publisher and subscribes to each raw (the CDR bytes are forwarded, never re-serialised);
unlike it, an observer: best-effort keep-last readers (latched topics: reliable depth 1,
as published), so a slow bridge or client can never hold up a writer or the lockstep.
Prints ``FOXGLOVE_URL ws://host:port`` once it serves.
"""
from __future__ import annotations

import sys
from functools import partial

from ament_index_python.packages import PackageNotFoundError
from rclpy.clock import Clock, ClockType
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from drill_bag import mcap_io
from drill_bag.recorder import offer_from_profile
from drill_ros import topics
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.status import StatusReporter
from drill_gateway.foxglove_bridge import DEFAULT_PORT, HOST, Bridge

OBSERVER = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                      reliability=ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.VOLATILE)


class FoxgloveBridgeNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("foxglove_bridge", **node_options)
        host = self.declare_parameter("host", HOST).value
        port = int(self.declare_parameter("port", DEFAULT_PORT).value)
        period_s = float(self.declare_parameter("discovery_period_s", 0.5).value)
        mode = self.declare_parameter("mode", "fast").value
        self.bridge = Bridge(host, port)
        self.status = StatusReporter(self, mode)
        self.forwarded = 0
        self._skipped: set[str] = set()
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(period_s, self.discover, clock=steady)
        self.create_timer(1.0, self._tick, clock=steady)
        self.discover()
        self.get_logger().info(f"Foxglove bridge on {self.bridge.url}")
        print(f"FOXGLOVE_URL {self.bridge.url}", flush=True)

    def discover(self) -> None:
        """Advertise and subscribe to every topic with a publisher not streamed yet."""
        for topic, types in self.get_topic_names_and_types():
            if topic in self._skipped or not self.bridge.wants(topic):
                continue
            infos = self.get_publishers_info_by_topic(topic)
            if not infos:
                continue
            latched = mcap_io.is_latched([offer_from_profile(i.qos_profile) for i in infos])
            try:
                msg_type = mcap_io.message_class(types[0])
                self.bridge.add(topic, types[0])
            except (ImportError, AttributeError, OSError, ValueError, PackageNotFoundError) as exc:
                self._skipped.add(topic)
                self.status.error(f"cannot stream {topic} [{types[0]}]: {exc}")
                continue
            self.create_subscription(msg_type, topic, partial(self._forward, topic),
                                     topics.LATCHED if latched else OBSERVER, raw=True)

    def _forward(self, topic: str, data: bytes) -> None:
        self.bridge.forward(topic, data)
        self.forwarded += 1

    def _tick(self) -> None:
        self.status.values = {"port": float(self.bridge.port),
                              "topics": float(len(self.bridge.topics)),
                              "messages_forwarded": float(self.forwarded)}
        self.status.tick(self.get_clock().now().nanoseconds)

    def destroy_node(self):
        self.bridge.close()
        return super().destroy_node()


def main(args=None) -> None:
    sys.exit(run(FoxgloveBridgeNode, args))


if __name__ == "__main__":
    main()
