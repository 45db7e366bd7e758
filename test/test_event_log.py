"""The event topics are event logs: a reader that matches the publisher only after events
went out (the recorder on a busy machine, a console opened mid-run) still receives them,
in order, from the publisher's history; and the recorder subscribes to them that way."""
from __future__ import annotations

import pytest
from drill_msgs.msg import OperatorEvent
from rig_testing import held_test_domain, spinning_node, wait_for

from drill_bag.recorder import offer_from_profile, subscription_qos
from drill_ros import graph, topics
from rclpy.qos import DurabilityPolicy

pytestmark = [pytest.mark.dds,
              pytest.mark.filterwarnings("ignore::DeprecationWarning")]
DOMAIN_ID = held_test_domain()
TOPIC = "/event_log_test/events"


def test_a_late_reader_gets_the_events_published_before_it(monkeypatch):
    with spinning_node(DOMAIN_ID, "event_log_writer", monkeypatch) as writer:
        pub = writer.create_publisher(OperatorEvent, TOPIC, topics.EVENT_LOG)
        for i in range(3):
            pub.publish(OperatorEvent(code=f"event_{i}"))
        received: list[str] = []
        with spinning_node(DOMAIN_ID, "event_log_reader", monkeypatch) as reader:
            reader.create_subscription(OperatorEvent, TOPIC, lambda m: received.append(m.code),
                                       topics.EVENT_LOG)
            wait_for(lambda: len(received) >= 3, 20.0, "the three events published before")
    assert received == ["event_0", "event_1", "event_2"]


def test_every_event_topic_is_an_event_log_the_recorder_reads_as_one():
    for name in (topics.OPERATOR_EVENTS, topics.PROTECTION_EVENTS, topics.RIG_EVENTS):
        assert graph.QOS_PROFILES[graph.BY_TOPIC[name].qos] is topics.EVENT_LOG, name
    qos = subscription_qos([offer_from_profile(topics.EVENT_LOG)])
    assert qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
