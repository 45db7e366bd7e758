"""The container's local bus (drill_ros.local_bus)."""
from std_msgs.msg import Float64

from drill_ros.local_bus import LocalBus


def test_local_topics_are_queued_in_order_and_copied_field_by_field():
    bus = LocalBus(["/a"])
    got = []
    assert bus.subscribe("/a", lambda m: got.append(("first", m.data)))
    assert bus.subscribe("/a", lambda m: got.append(("second", m.data)))
    assert not bus.subscribe("/b", got.append)         # not local: the middleware's
    msg = Float64(data=1.0)
    bus.publish("/a", msg)
    msg.data = 2.0                                      # the publisher reuses its message
    bus.publish("/a", msg)
    bus.publish("/b", msg)                              # no local subscriber: nothing queued
    assert got == [] and bus.pending                    # nothing runs inside a publish
    assert bus.deliver() == 4 and not bus.pending
    assert got == [("first", 1.0), ("second", 1.0), ("first", 2.0), ("second", 2.0)]


def test_messages_published_by_a_delivered_callback_are_delivered_too():
    bus = LocalBus(["/ping", "/pong"])
    got = []
    bus.subscribe("/ping", lambda m: bus.publish("/pong", Float64(data=m.data + 1.0)))
    bus.subscribe("/pong", lambda m: got.append(m.data))
    bus.publish("/ping", Float64(data=1.0))
    assert bus.deliver() == 2 and got == [2.0]


def test_a_topic_published_elsewhere_is_taken_once_and_handed_to_each_subscriber():
    bus = LocalBus([])
    made, got = [], []

    def create(fan_out):                   # stands for the middleware subscription
        made.append(fan_out)
        return "subscription"

    assert bus.share("/x", lambda m: got.append(("first", m.data)), create) == "subscription"
    assert bus.share("/x", lambda m: (got.append(("second", m.data)),
                                      setattr(m, "data", -1.0)), create) is None
    assert bus.share("/x", lambda m: got.append(("third", m.data)), create) is None
    assert len(made) == 1                  # one subscription for the process
    msg = Float64(data=3.0)
    made[0](msg)                           # a message taken from the middleware
    assert got == [("first", 3.0), ("second", 3.0), ("third", 3.0)]   # each its own copy
    assert msg.data == 3.0 and not bus.pending
