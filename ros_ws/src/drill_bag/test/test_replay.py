"""Replay: pure helpers, and replays of a file written with mcap_io into subscribers here."""
import os
import subprocess
import sys
import threading
import time

import pytest
import rclpy
from drill_msgs.msg import NodeStatus, RigMeasurement, Setpoints
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock

from rig_testing import held_test_domain, spinning_node, wait_for

from drill_bag import mcap_io, replay
from drill_bag.mcap_io import QosOffer, RecordedMessage

T0_NS = 50 * 10**9
PERIOD_NS = 25_000_000
N_MEASUREMENTS = 40
SPAN_S = (N_MEASUREMENTS - 1) * PERIOD_NS / 1e9
N_STATUS = 5
LATCHED = QosOffer(depth=1, durability=mcap_io.TRANSIENT_LOCAL)
KEEP_ALL_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
LATCHED_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


# ---------------------------------------------------------------- pure helpers

def test_topic_selection_is_union_of_list_and_regex_minus_exclusions():
    names = ["/a", "/b/x", "/b/y", "/c"]
    assert replay.select_topics(names) == names
    assert replay.select_topics(names, topics=["/a"]) == ["/a"]
    assert replay.select_topics(names, topics=["/a"], regex="^/b") == ["/a", "/b/x", "/b/y"]
    assert replay.select_topics(names, exclude_regex="y$") == ["/a", "/b/x", "/c"]
    assert replay.select_topics(names, regex="^/b", exclude_regex="x") == ["/b/y"]


def test_ros_args_are_split_from_tool_args():
    argv = ["replay", "f.mcap", "--ros-args", "-p", "use_sim_time:=false", "--", "--remap",
            "/a:=/b"]
    assert replay.split_ros_args(argv) == (
        ["replay", "f.mcap", "--remap", "/a:=/b"], ["--ros-args", "-p", "use_sim_time:=false"])


def test_remaps_parse_and_reject_garbage():
    assert replay.parse_remaps(["/a:=/b", "/c:=/d"]) == {"/a": "/b", "/c": "/d"}
    with pytest.raises(ValueError):
        replay.parse_remaps(["/a=/b"])


def test_latest_per_topic_keeps_the_last_message_of_each_topic():
    def msg(topic, t):
        return RecordedMessage(topic, "x/msg/Y", t, t, b"", "")
    latest = replay.latest_per_topic([msg("/a", 1), msg("/b", 2), msg("/a", 3)])
    assert [(m.topic, m.log_time_ns) for m in latest] == [("/b", 2), ("/a", 3)]


def test_timebase_scales_recording_time_by_rate():
    timebase = replay.Timebase(recording_start_ns=10**9, wall_start_s=100.0, rate=10.0)
    assert timebase.to_wall_s(2 * 10**9) == pytest.approx(100.1)
    assert timebase.to_recording_ns(100.1) == pytest.approx(2 * 10**9, abs=10)


def test_publisher_qos_follows_recorded_offers():
    latched = replay.publisher_qos([LATCHED, LATCHED])
    assert (latched.durability, latched.depth) == (DurabilityPolicy.TRANSIENT_LOCAL, 1)
    best_effort = replay.publisher_qos([QosOffer(reliability=mcap_io.BEST_EFFORT, history=3,
                                                 deadline_ns=mcap_io.INFINITE_NS)])
    assert best_effort.reliability == ReliabilityPolicy.BEST_EFFORT
    assert best_effort.history == HistoryPolicy.KEEP_LAST
    mixed = replay.publisher_qos([LATCHED, QosOffer()])
    assert mixed.durability == DurabilityPolicy.VOLATILE
    reliable = replay.publisher_qos([QosOffer(reliability=mcap_io.RELIABLE)])
    assert reliable.history == HistoryPolicy.KEEP_ALL


# ---------------------------------------------------------------- DDS

def write_recording(path):
    """Latched setpoints at T0, measurements every 25 ms, a few status messages."""
    with mcap_io.McapWriter(path) as writer:
        writer.add_topic("/setpoints", "drill_msgs/msg/Setpoints", [LATCHED])
        writer.add_topic("/rig/measurement", "drill_msgs/msg/RigMeasurement", [QosOffer()])
        writer.add_topic("/x/status", "drill_msgs/msg/NodeStatus", [QosOffer()])
        writer.write("/setpoints", serialize_message(Setpoints(bhp_ref_pa=2.5e7)), T0_NS)
        for i in range(N_MEASUREMENTS):
            writer.write("/rig/measurement", serialize_message(RigMeasurement(bhp_pa=float(i))),
                         T0_NS + i * PERIOD_NS)
        for i in range(N_STATUS):
            writer.write("/x/status", serialize_message(NodeStatus(node=f"n{i}")),
                         T0_NS + i * 200_000_000)
    return path


class Inbox:
    """Subscribers on the replayed topics, recording (receipt time, message)."""

    def __init__(self, node, measurement_topic="/rig/measurement"):
        self.measurements, self.setpoints, self.status, self.clock = [], [], [], []
        for msg_type, topic, box, qos in (
                (RigMeasurement, measurement_topic, self.measurements, KEEP_ALL_QOS),
                (Setpoints, "/setpoints", self.setpoints, LATCHED_QOS),
                (NodeStatus, "/x/status", self.status, KEEP_ALL_QOS),
                (Clock, "/clock", self.clock, KEEP_ALL_QOS)):
            node.create_subscription(msg_type, topic,
                                     lambda m, box=box: box.append((time.monotonic(), m)), qos)

    def values(self):
        return [m.bhp_pa for _, m in self.measurements]

    def clock_ns(self):
        return [m.clock.sec * 10**9 + m.clock.nanosec for _, m in self.clock]


@pytest.mark.dds
def test_replay_file_republishes_everything_in_order_at_rate_with_clock(tmp_path, monkeypatch):
    path = write_recording(tmp_path / "rec.mcap")
    with spinning_node(held_test_domain(), "listener", monkeypatch) as node:
        inbox = Inbox(node)
        player = rclpy.create_node("replay", context=node.context)
        count = replay.replay_file(path, rate=10.0, clock_hz=100.0, node=player, delay_s=0.2,
                                   wait_for_subscribers=True)
        wait_for(lambda: len(inbox.measurements) == N_MEASUREMENTS
                 and len(inbox.status) == N_STATUS, 15, "replayed messages")
        player.destroy_node()
    assert count == 1 + N_MEASUREMENTS + N_STATUS
    assert inbox.values() == [float(i) for i in range(N_MEASUREMENTS)]
    assert [m.bhp_ref_pa for _, m in inbox.setpoints] == [2.5e7]
    assert [m.node for _, m in inbox.status] == [f"n{i}" for i in range(N_STATUS)]
    receipt_span_s = inbox.measurements[-1][0] - inbox.measurements[0][0]
    assert 0.8 * SPAN_S / 10 <= receipt_span_s < 0.6 * SPAN_S
    clock_ns = inbox.clock_ns()
    assert len(clock_ns) >= 3 and clock_ns == sorted(clock_ns)
    assert T0_NS <= clock_ns[0] and clock_ns[-1] <= T0_NS + SPAN_S * 1e9 + 2e8


@pytest.mark.dds
def test_replay_cli_filters_topics_skips_start_and_keeps_latched(tmp_path, monkeypatch):
    path = write_recording(tmp_path / "rec.mcap")
    domain = held_test_domain()
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    with spinning_node(domain, "listener", monkeypatch) as node:
        inbox = Inbox(node, measurement_topic="/replayed/measurement")
        result = subprocess.run(
            [sys.executable, "-m", "drill_bag.replay", str(path), "--rate", "10",
             "--topics", "/rig/measurement", "/setpoints", "--start-offset", "0.5",
             "--clock", "100", "--remap", "/rig/measurement:=/replayed/measurement",
             "--delay", "0.2", "--wait-for-subscribers"],
            env=env, capture_output=True, text=True, timeout=30)
        assert result.returncode == 0, result.stderr
        first_kept = int(0.5e9 / PERIOD_NS)
        wait_for(lambda: len(inbox.measurements) == N_MEASUREMENTS - first_kept, 5,
                 "replayed measurements")
        time.sleep(0.2)
    assert inbox.values() == [float(i) for i in range(first_kept, N_MEASUREMENTS)]
    assert [m.bhp_ref_pa for _, m in inbox.setpoints] == [2.5e7]
    assert inbox.status == []
    assert inbox.clock and min(inbox.clock_ns()) >= T0_NS + 5 * 10**8


@pytest.mark.dds
def test_replay_loops_until_stopped(tmp_path, monkeypatch):
    path = write_recording(tmp_path / "rec.mcap")
    stop = threading.Event()
    with spinning_node(held_test_domain(), "listener", monkeypatch) as node:
        inbox = Inbox(node)
        player = rclpy.create_node("replay", context=node.context)
        thread = threading.Thread(target=replay.replay_file, args=(path,), kwargs=dict(
            rate=20.0, loop=True, topics=["/rig/measurement"], wait_for_subscribers=True,
            node=player, stop=stop))
        thread.start()
        wait_for(lambda: len(inbox.measurements) > 2 * N_MEASUREMENTS, 10, "a third pass")
        stop.set()
        thread.join(timeout=5)
        player.destroy_node()
    assert not thread.is_alive()
    one_pass = [float(i) for i in range(N_MEASUREMENTS)]
    assert inbox.values()[:2 * N_MEASUREMENTS] == one_pass + one_pass
