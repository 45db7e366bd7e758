"""Base class of the rig's nodes: an rclpy Node with a lean wait set.

rclpy's executor adds every entity of a node to its wait set on each spin, in Python,
and the lockstep spins several times per 0.1 s frame in every process. Two kinds of
entity the rig does not use are therefore left out:

* the parameter services (get/set/list/describe): the rig's parameters are fixed at
  launch from ``config/`` and the scenario, and nothing here changes them at run time;
* the default QoS-event handlers of every publisher and subscription (they only log a
  warning on incompatible QoS or type; the launcher's graph check in the plant node
  already refuses to start until every expected endpoint has matched).
"""
from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node


class RigNode(Node):
    """rclpy Node without parameter services or default QoS-event handlers."""

    def __init__(self, node_name: str, **kwargs):
        kwargs.setdefault("start_parameter_services", False)
        super().__init__(node_name, **kwargs)

    def create_publisher(self, *args, **kwargs):
        kwargs.setdefault("event_callbacks", PublisherEventCallbacks(use_default_callbacks=False))
        return super().create_publisher(*args, **kwargs)

    def create_subscription(self, *args, **kwargs):
        kwargs.setdefault("event_callbacks",
                          SubscriptionEventCallbacks(use_default_callbacks=False))
        return super().create_subscription(*args, **kwargs)
