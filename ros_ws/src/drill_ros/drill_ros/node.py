"""Base class of the rig's nodes: an rclpy Node with a lean wait set.

rclpy's executor adds every entity of a node to its wait set on each spin, in Python,
and the lockstep spins several times per 0.1 s frame in every process. Two kinds of
entity the rig does not use are therefore left out:

* the parameter services (get/set/list/describe): the rig's parameters are fixed at
  launch from ``config/`` and the scenario, and nothing here changes them at run time;
* the default QoS-event handlers of every publisher and subscription (they only log a
  warning on incompatible QoS or type; the launcher's graph check in the plant node
  already refuses to start until every expected endpoint has matched).

In a container, a subscription whose topic only this process publishes takes its messages
from the process's local bus (drill_ros.local_bus) instead of the middleware, and
the nodes there that subscribe to one reliable topic published elsewhere share one
middleware subscription to it.

A node that ends the run (the plant at the scenario's end, the estimator after the last
sample) calls ``finish``: on its own it shuts its process down; in a container
(drill_ros.container) it only marks itself finished, and once every finishing node
there has, the container tells the launcher so and spins on until it is stopped.

In fast mode the launcher also gives each node ``match_before_first_publish`` (``topic:N``,
drill_ros.graph.first_publish_matches): the first message on such a topic waits until
its publisher has matched N subscriptions, so no reader misses the lockstep's first sample.
"""
from __future__ import annotations

import time

import rclpy
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node

from drill_ros import topics
from drill_ros.budget import NodeBudget
from drill_ros.stopping import PROCESS

MATCH_TIMEOUT_S = 30.0      # a first publish waits at most this long for its readers
# set by drill_ros.container: whether nodes share a process, and its local bus
CONTAINED = {"active": False, "bus": None}


class RigNode(Node):
    """rclpy Node without parameter services or default QoS-event handlers."""

    def __init__(self, node_name: str, **kwargs):
        kwargs.setdefault("start_parameter_services", False)
        self._matches: dict[str, int] | None = None     # rclpy's own publishers come first
        self.budget = NodeBudget()
        super().__init__(node_name, **kwargs)
        specs = self.declare_parameter("match_before_first_publish", [""]).value
        self._matches = {topic: int(count) for topic, _, count in
                         (spec.rpartition(":") for spec in specs if spec)}
        self.finished = False

    def finish(self) -> None:
        """This node's part of the run is over: shut the process down, or, in a container,
        leave that to the container."""
        self.finished = True
        if not CONTAINED["active"]:
            rclpy.try_shutdown()

    def create_publisher(self, *args, **kwargs):
        kwargs.setdefault("event_callbacks", PublisherEventCallbacks(use_default_callbacks=False))
        publisher = super().create_publisher(*args, **kwargs)
        topic = kwargs.get("topic", args[1] if len(args) > 1 else "")
        self._time_publish(publisher, (self._matches or {}).get(topic))
        return publisher

    def _time_publish(self, publisher, expected: int | None) -> None:
        """Count the time ``publisher`` spends publishing in the budget; with ``expected``,
        hold the first message until that many subscriptions have matched (DDS matches in
        its own threads, so waiting here does not stop it)."""
        original = publisher.publish
        budget = self.budget
        gate = [expected] if expected else []

        bus = CONTAINED["bus"]
        topic = publisher.topic_name

        def publish(msg):
            if gate:
                self._wait_for_matches(publisher, gate.pop())
            started = time.thread_time()
            original(msg)
            if bus is not None:
                bus.publish(topic, msg)
            budget.publish_cpu_s += time.thread_time() - started

        publisher.publish = publish

    def _wait_for_matches(self, publisher, expected: int) -> None:
        deadline = time.monotonic() + MATCH_TIMEOUT_S
        while publisher.get_subscription_count() < expected and time.monotonic() < deadline:
            if PROCESS.requested:         # stopping: no reader will come now
                return
            time.sleep(0.005)
        if publisher.get_subscription_count() < expected:
            self.get_logger().warning(
                f"{publisher.topic_name}: {publisher.get_subscription_count()} of {expected} "
                f"subscriptions matched after {MATCH_TIMEOUT_S:.0f} s; publishing anyway")

    def create_subscription(self, msg_type, topic, callback, *args, **kwargs):
        kwargs.setdefault("event_callbacks",
                          SubscriptionEventCallbacks(use_default_callbacks=False))
        bus = CONTAINED["bus"]
        timed = self._timed(callback)
        if bus is None:
            return super().create_subscription(msg_type, topic, timed, *args, **kwargs)
        if bus.subscribe(topic, timed):
            return None        # every publisher of the topic is in this process
        qos = kwargs.get("qos_profile", args[0] if args else None)
        create = super().create_subscription
        if qos != topics.RELIABLE:     # a latched value must reach each subscriber itself
            return create(msg_type, topic, timed, *args, **kwargs)
        return bus.share(topic, timed,
                         lambda fan_out: create(msg_type, topic, fan_out, *args, **kwargs))

    def _timed(self, callback):
        """``callback`` with its calls and time counted in the budget."""
        budget = self.budget

        def timed(msg):
            wall, cpu = time.perf_counter(), time.thread_time()
            try:
                return callback(msg)
            finally:
                budget.callbacks += 1
                budget.callback_s += time.perf_counter() - wall
                budget.callback_cpu_s += time.thread_time() - cpu
        return timed
