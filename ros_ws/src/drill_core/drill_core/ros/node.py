"""Base class of the rig's nodes: an rclpy Node with a lean wait set.

rclpy's executor adds every entity of a node to its wait set on each spin, in Python,
and the lockstep spins several times per 0.1 s frame in every process. Two kinds of
entity the rig does not use are therefore left out:

* the parameter services (get/set/list/describe): the rig's parameters are fixed at
  launch from ``config/`` and the scenario, and nothing here changes them at run time;
* the default QoS-event handlers of every publisher and subscription (they only log a
  warning on incompatible QoS or type; the launcher's graph check in the plant node
  already refuses to start until every expected endpoint has matched).

In fast mode the launcher also gives each node ``match_before_first_publish`` (``topic:N``,
drill_core.ros.graph.first_publish_matches): the first message on such a topic waits until
its publisher has matched N subscriptions, so no reader misses the lockstep's first sample.
"""
from __future__ import annotations

import time

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node

MATCH_TIMEOUT_S = 30.0      # a first publish waits at most this long for its readers


class RigNode(Node):
    """rclpy Node without parameter services or default QoS-event handlers."""

    def __init__(self, node_name: str, **kwargs):
        kwargs.setdefault("start_parameter_services", False)
        self._matches: dict[str, int] | None = None     # rclpy's own publishers come first
        super().__init__(node_name, **kwargs)
        specs = self.declare_parameter("match_before_first_publish", [""]).value
        self._matches = {topic: int(count) for topic, _, count in
                         (spec.rpartition(":") for spec in specs if spec)}

    def create_publisher(self, *args, **kwargs):
        kwargs.setdefault("event_callbacks", PublisherEventCallbacks(use_default_callbacks=False))
        publisher = super().create_publisher(*args, **kwargs)
        topic = kwargs.get("topic", args[1] if len(args) > 1 else "")
        expected = (self._matches or {}).get(topic)
        if expected:
            self._gate_first_publish(publisher, expected)
        return publisher

    def _gate_first_publish(self, publisher, expected: int) -> None:
        """Hold the first message until ``expected`` subscriptions have matched (DDS
        matches in its own threads, so waiting here does not stop it)."""
        original = publisher.publish

        def publish(msg):
            deadline = time.monotonic() + MATCH_TIMEOUT_S
            while publisher.get_subscription_count() < expected and time.monotonic() < deadline:
                time.sleep(0.005)
            if publisher.get_subscription_count() < expected:
                self.get_logger().warning(
                    f"{publisher.topic_name}: {publisher.get_subscription_count()} of {expected} "
                    f"subscriptions matched after {MATCH_TIMEOUT_S:.0f} s; publishing anyway")
            del publisher.publish          # the class's publish from now on
            original(msg)

        publisher.publish = publish

    def create_subscription(self, *args, **kwargs):
        kwargs.setdefault("event_callbacks",
                          SubscriptionEventCallbacks(use_default_callbacks=False))
        return super().create_subscription(*args, **kwargs)
