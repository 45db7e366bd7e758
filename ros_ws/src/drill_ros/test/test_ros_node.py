"""RigNode: no parameter services and no default QoS-event handlers in the wait set; its
callbacks and publishing counted in the time budget."""
import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from std_msgs.msg import Bool

from drill_ros.node import RigNode
from rig_testing import held_test_domain


@pytest.fixture
def context():
    ctx = Context()
    rclpy.init(context=ctx, domain_id=held_test_domain())
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
        pub.publish(Bool(data=True))                    # returns once the reader has matched
        assert pub.get_subscription_count() == 1
        assert node.budget.publish_cpu_s > 0.0          # publishing is in the time budget
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        for _ in range(60):                             # the message is in flight: take it
            if got:
                break
            executor.spin_once(timeout_sec=1.0)
        executor.remove_node(node)
        assert node.budget.callbacks == 1 and node.budget.callback_cpu_s > 0.0
    finally:
        node.destroy_node()


def test_the_scenario_clock_counts_from_the_first_measurement():
    from drill_ros.stamps import ScenarioClock
    clock = ScenarioClock()
    assert clock.seconds(5_000_000_000) == 0.0          # before the first measurement
    clock.start(2_000_000_000)
    clock.start(3_000_000_000)                           # the first one stays
    assert clock.seconds(4_500_000_000) == 2.5
