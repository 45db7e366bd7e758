"""Recorder: pure helpers, and real recorder processes fed by a publisher in this process."""
import json
import os
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import pytest
import yaml
from drill_msgs.msg import NodeStatus, RigMeasurement, Setpoints
from mcap.reader import make_reader
from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader
from rosgraph_msgs.msg import Clock

from rig_testing import held_test_domain, spinning_node, wait_for

from drill_bag import mcap_io, recorder
from drill_bag.mcap_io import QosOffer

N_MESSAGES = 200
MCAP_MAGIC = b"\x89MCAP0\r\n"
LATCHED_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
KEEP_ALL_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
SIM_TIME_NS = 1_234_500_000_000


# ---------------------------------------------------------------- pure helpers

def test_topic_filter_uses_list_then_exclude_regex():
    assert recorder.wanted("/a", [], "")
    assert not recorder.wanted("/a", ["/b"], "")
    assert recorder.wanted("/b", ["/b"], "")
    assert not recorder.wanted("/rosout", [], "^/ros")
    assert recorder.wanted("/rig/rosout", [], "^/ros")


def test_subscription_is_latched_and_reliable_only_when_every_offer_is():
    latched = QosOffer(durability=mcap_io.TRANSIENT_LOCAL)
    best_effort = QosOffer(reliability=mcap_io.BEST_EFFORT)
    qos = recorder.subscription_qos([latched, latched])
    assert qos.history == HistoryPolicy.KEEP_ALL
    assert (qos.durability, qos.reliability) == (DurabilityPolicy.TRANSIENT_LOCAL,
                                                 ReliabilityPolicy.RELIABLE)
    assert recorder.subscription_qos([latched, QosOffer()]).durability == \
        DurabilityPolicy.VOLATILE
    assert recorder.subscription_qos([latched, best_effort]).reliability == \
        ReliabilityPolicy.BEST_EFFORT


def test_offer_from_profile_keeps_policies_and_durations():
    profile = QoSProfile(depth=7, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         lifespan=Duration(seconds=2))
    offer = recorder.offer_from_profile(profile)
    assert (offer.depth, offer.durability, offer.lifespan_ns) == (7, mcap_io.TRANSIENT_LOCAL,
                                                                  2 * 10**9)


def test_status_values_list_counts_and_total():
    keys, values = recorder.status_values({"/b": 2, "/a": 3})
    assert keys == ["messages/a", "messages/b", "messages_total"]
    assert values == [3.0, 2.0, 5.0]


# ---------------------------------------------------------------- processes

def dds_env(domain_id: int) -> dict:
    return dict(os.environ, ROS_DOMAIN_ID=str(domain_id),
                ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")


def start_recorder(output: Path, domain_id: int, *params: str) -> subprocess.Popen:
    args = ["-p", f"output:={output}"] + [arg for p in params for arg in ("-p", p)]
    return subprocess.Popen([sys.executable, "-m", "drill_bag.recorder", "--ros-args", *args],
                            env=dds_env(domain_id), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)


@contextmanager
def recorder_process(output: Path, domain_id: int, *params: str):
    process = start_recorder(output, domain_id, *params)
    try:
        yield process
    finally:
        if process.poll() is None:
            process.kill()
        process.communicate(timeout=10)


def recorded(statuses, topic: str) -> int:
    """Count of a topic in the latest recorder status, -1 before any."""
    if not statuses:
        return -1
    values = dict(zip(statuses[-1].keys, statuses[-1].values))
    return int(values.get(f"messages{topic}", -1))


def publish_run(node, n: int) -> list:
    """Latched setpoints plus n measurements once the recorder listens; returns status list."""
    statuses = []
    node.create_subscription(NodeStatus, recorder.STATUS_TOPIC, statuses.append, 10)
    node.create_publisher(Setpoints, "/setpoints", LATCHED_QOS).publish(
        Setpoints(bhp_ref_pa=3.0e7, source="test"))
    publisher = node.create_publisher(RigMeasurement, "/rig/measurement", KEEP_ALL_QOS)
    wait_for(lambda: publisher.get_subscription_count() > 0
             and recorded(statuses, "/rig/measurement") >= 0, 15,
             "recorder subscription and a status listing it")
    for i in range(n):
        msg = RigMeasurement(bhp_pa=float(i), block_position_m=-0.01 * i)
        msg.header.stamp.sec, msg.header.stamp.nanosec = i + 1, 500
        publisher.publish(msg)
    assert publisher.wait_for_all_acked(Duration(seconds=10))
    return statuses


def wait_recorded(statuses, n: int) -> None:
    wait_for(lambda: recorded(statuses, "/rig/measurement") == n
             and recorded(statuses, "/setpoints") == 1, 10, "recorder status counts")


@pytest.mark.dds
def test_recorder_records_a_publisher_process_and_closes_on_sigint(tmp_path, monkeypatch):
    output = tmp_path / "run.mcap"
    wall_start_ns = time.time_ns()
    domain = held_test_domain()
    with recorder_process(output, domain) as process:
        with spinning_node(domain, "publisher", monkeypatch) as node:
            statuses = publish_run(node, N_MESSAGES)
        process.send_signal(signal.SIGINT)  # at once: what is still queued must be drained
        assert process.wait(timeout=10) == 0
    wall_end_ns = time.time_ns()
    assert statuses[-1].node == "recorder" and statuses[-1].mode == "wall_time/recording"
    assert {"messages/rig/measurement", "messages_total"} <= set(statuses[-1].keys)

    counts = json.loads(Path(f"{output}.counts.json").read_text())
    assert counts["/rig/measurement"] == N_MESSAGES and counts["/setpoints"] == 1
    assert counts["/recorder/status"] >= 1

    with AnyReader([output]) as reader:
        by_topic = {c.topic: c for c in reader.connections}
        values = [reader.deserialize(raw, c.msgtype).bhp_pa
                  for c, _, raw in reader.messages(connections=[by_topic["/rig/measurement"]])]
        [(c, _, raw)] = list(reader.messages(connections=[by_topic["/setpoints"]]))
        assert reader.deserialize(raw, c.msgtype).bhp_ref_pa == 3.0e7
    assert values == [float(i) for i in range(N_MESSAGES)]

    measurements = list(mcap_io.read_messages(output, ["/rig/measurement"]))
    assert [m.publish_time_ns for m in measurements] == \
        [(i + 1) * 10**9 + 500 for i in range(N_MESSAGES)]
    assert all(wall_start_ns <= m.log_time_ns <= wall_end_ns for m in measurements)

    with open(output, "rb") as stream:
        reader = make_reader(stream)
        channels = {c.topic: c for c in reader.get_summary().channels.values()}
        metadata = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
    setpoints_qos = yaml.safe_load(channels["/setpoints"].metadata["offered_qos_profiles"])
    measurement_qos = yaml.safe_load(
        channels["/rig/measurement"].metadata["offered_qos_profiles"])
    assert setpoints_qos[0]["durability"] == "transient_local"
    assert measurement_qos[0]["durability"] == "volatile"
    assert measurement_qos[0]["reliability"] == "reliable"
    assert channels["/rig/measurement"].metadata["topic_type_hash"].startswith("RIHS01_")
    bag = yaml.safe_load(metadata[0].metadata["serialized_metadata"])
    assert bag["message_count"] == sum(counts.values())


@pytest.mark.dds
def test_recorder_uses_sim_time_and_closes_on_sigterm(tmp_path, monkeypatch):
    output = tmp_path / "sim.mcap"
    domain = held_test_domain()
    with recorder_process(output, domain, "use_sim_time:=true",
                          "topics:=[/rig/measurement, /setpoints]") as process:
        with spinning_node(domain, "sim", monkeypatch) as node:
            clock = node.create_publisher(Clock, "/clock", 10)
            tick = Clock()
            tick.clock.sec, tick.clock.nanosec = divmod(SIM_TIME_NS, 10**9)
            node.create_timer(0.02, lambda: clock.publish(tick))
            wait_recorded(publish_run(node, 20), 20)
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=10) == 0
    assert set(mcap_io.topics(output)) == {"/rig/measurement", "/setpoints"}
    log_times_ns = {m.log_time_ns for m in mcap_io.read_messages(output, ["/rig/measurement"])}
    assert log_times_ns == {SIM_TIME_NS}


@pytest.mark.dds
def test_hard_killed_recorder_file_is_recoverable(tmp_path, monkeypatch):
    output = tmp_path / "killed.mcap"
    domain = held_test_domain()
    with recorder_process(output, domain, "chunk_size_bytes:=1024") as process:
        with spinning_node(domain, "publisher", monkeypatch) as node:
            wait_recorded(publish_run(node, N_MESSAGES), N_MESSAGES)
        process.send_signal(signal.SIGKILL)
        assert process.wait(timeout=10) == -signal.SIGKILL
    assert not output.read_bytes().endswith(MCAP_MAGIC)
    assert not Path(f"{output}.counts.json").exists()

    measurements = [m for m in mcap_io.recover(output) if m.topic == "/rig/measurement"]
    values = [deserialize_message(m.data, RigMeasurement).bhp_pa for m in measurements]
    assert 150 <= len(values) <= N_MESSAGES
    assert values == [float(i) for i in range(len(values))]
    assert [mcap_io.decode(m).bhp_pa for m in measurements] == values
