"""RigNode: no parameter services and no default QoS-event handlers in the wait set."""
import pytest
import rclpy
from rclpy.context import Context
from std_msgs.msg import Bool

from drill_core.ros.node import RigNode


@pytest.fixture
def context():
    ctx = Context()
    rclpy.init(context=ctx, domain_id=47)
    yield ctx
    rclpy.shutdown(context=ctx)


def test_rig_node_waits_only_on_what_it_creates(context):
    node = RigNode("lean", context=context)
    plain = rclpy.create_node("plain", context=context)
    try:
        services = [s.srv_name for s in node.services]
        assert not any("parameter" in name for name in services), services
        assert any("parameter" in s.srv_name for s in plain.services)     # what was left out
        sub = node.create_subscription(Bool, "/x", lambda _: None, 10)
        pub = node.create_publisher(Bool, "/x", 10)
        assert sub.event_handlers == [] and pub.event_handlers == []
        assert plain.create_publisher(Bool, "/x", 10).event_handlers          # rclpy's default
        assert node.get_parameter("use_sim_time").value is False           # parameters still work
    finally:
        node.destroy_node()
        plain.destroy_node()


def test_a_first_publish_waits_for_its_readers_to_match(context):
    from rclpy.parameter import Parameter
    node = RigNode("gated", context=context, parameter_overrides=[
        Parameter("match_before_first_publish", value=["/y:1"])])
    try:
        got = []
        node.create_subscription(Bool, "/y", got.append, 10)
        pub = node.create_publisher(Bool, "/y", 10)
        other = node.create_publisher(Bool, "/z", 10)
        assert "publish" in vars(pub) and "publish" not in vars(other)    # only /y is gated
        pub.publish(Bool(data=True))                    # returns once the reader has matched
        assert pub.get_subscription_count() == 1
        assert "publish" not in vars(pub)               # later messages go straight out
    finally:
        node.destroy_node()
