"""The container's local bus (drill_core.ros.local_bus)."""
from std_msgs.msg import Float64

from drill_core.ros.local_bus import LocalBus


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
