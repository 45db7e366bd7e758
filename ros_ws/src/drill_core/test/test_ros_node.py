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
