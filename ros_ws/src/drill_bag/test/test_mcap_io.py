"""mcap_io without DDS: definitions, QoS metadata, writer/reader round trip, recovery."""
import struct

import pytest
import yaml
from drill_msgs.msg import RigMeasurement, Setpoints
from mcap.reader import make_reader
from mcap.records import Chunk, Message
from mcap.stream_reader import StreamReader, breakup_chunk
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.highlevel import AnyReader
from std_msgs.msg import String

from drill_bag import mcap_io
from drill_bag.mcap_io import QosOffer

DELIMITER_LINE = "\n" + "=" * 80 + "\n"
T0_NS = 1_000_000_000
LATCHED = QosOffer(depth=1, durability=mcap_io.TRANSIENT_LOCAL)


def measurement(i: int) -> bytes:
    msg = RigMeasurement(bhp_pa=float(i), choke_dp_pa=2.0 * i)
    msg.header.stamp.sec, msg.header.stamp.nanosec = 100 + i, 7
    return serialize_message(msg)


def write_sample(path, n=50, chunk_size_bytes=mcap_io.DEFAULT_CHUNK_SIZE_BYTES):
    """n measurements 10 ms apart, one latched setpoint, one headerless String."""
    with mcap_io.McapWriter(path, chunk_size_bytes=chunk_size_bytes) as writer:
        writer.add_topic("/rig/measurement", "drill_msgs/msg/RigMeasurement", [QosOffer()],
                         "RIHS01_test")
        writer.add_topic("/setpoints", "drill_msgs/msg/Setpoints", [LATCHED])
        writer.add_topic("/note", "std_msgs/msg/String", [QosOffer()])
        writer.write("/setpoints", serialize_message(Setpoints(bhp_ref_pa=3.0e7)), T0_NS)
        for i in range(n):
            writer.write("/rig/measurement", measurement(i), T0_NS + i * 10_000_000)
        writer.write("/note", serialize_message(String(data="hi")), T0_NS + 5)
    return path


def test_rig_measurement_definition_is_dependency_expanded():
    text = mcap_io.message_definition("drill_msgs/msg/RigMeasurement")
    header = DELIMITER_LINE + "MSG: std_msgs/Header\n"
    time = DELIMITER_LINE + "MSG: builtin_interfaces/Time\n"
    assert text.startswith(mcap_io.msg_text("drill_msgs", "RigMeasurement"))
    assert header in text and time in text
    assert text.index(header) < text.index(time)
    assert text.count("MSG: ") == 2
    assert "int32 sec" in text.split(time)[1]
    assert all(len(line) == 80 for line in text.splitlines() if line.startswith("="))


def test_definition_resolves_bare_names_and_lists_each_dependency_once():
    files = {
        ("a", "Outer"): "Inner first  # comment\nInner[] more\nb/Leaf[<=3] leaf\nint32 X=1\n",
        ("a", "Inner"): "b/Leaf leaf\nstring<=5 name\n",
        ("b", "Leaf"): "float64[3] v\n",
    }
    text = mcap_io.message_definition("a/msg/Outer", lambda pkg, name: files[(pkg, name)])
    assert text.count("MSG: a/Inner\n") == 1
    assert text.count("MSG: b/Leaf\n") == 1
    assert "MSG: int32" not in text and "MSG: string" not in text


def test_qos_yaml_is_rosbag2_v9_and_round_trips():
    offers = [QosOffer(history=3, depth=0, deadline_ns=mcap_io.INFINITE_NS, liveliness=1,
                       lifespan_ns=10_500_000_000), LATCHED]
    text = mcap_io.offered_qos_yaml(offers)
    nodes = yaml.safe_load(text)
    assert list(nodes[0]) == ["history", "depth", "reliability", "durability", "deadline",
                              "lifespan", "liveliness", "liveliness_lease_duration",
                              "avoid_ros_namespace_conventions"]
    assert nodes[0]["history"] == "unknown" and nodes[0]["liveliness"] == "automatic"
    assert nodes[0]["deadline"] == {"sec": 9223372036, "nsec": 854775807}
    assert nodes[0]["lifespan"] == {"sec": 10, "nsec": 500_000_000}
    assert nodes[1]["durability"] == "transient_local" and nodes[1]["reliability"] == "reliable"
    assert mcap_io.parse_offered_qos(text) == offers


def test_qos_parser_reads_integer_policies_of_older_bags():
    old = ("- history: 1\n  depth: 5\n  reliability: 2\n  durability: 1\n"
           "  deadline: {sec: 0, nsec: 0}\n  lifespan: {sec: 0, nsec: 0}\n  liveliness: 1\n"
           "  liveliness_lease_duration: {sec: 0, nsec: 0}\n"
           "  avoid_ros_namespace_conventions: false\n")
    [offer] = mcap_io.parse_offered_qos(old)
    assert (offer.depth, offer.reliability, offer.durability) == (5, mcap_io.BEST_EFFORT,
                                                                  mcap_io.TRANSIENT_LOCAL)
    assert mcap_io.is_latched([offer]) and not mcap_io.is_latched([offer, QosOffer()])


def test_header_stamp_is_read_from_cdr_in_either_byte_order():
    assert mcap_io.header_stamp_ns(measurement(3)) == 103 * 10**9 + 7
    big_endian = b"\x00\x00\x00\x00" + struct.pack(">iI", 5, 9) + b"\x00" * 8
    assert mcap_io.header_stamp_ns(big_endian) == 5 * 10**9 + 9
    assert mcap_io.header_stamp_ns(b"\x00\x01") is None
    assert mcap_io.starts_with_header(mcap_io.msg_text("drill_msgs", "Setpoints"))
    assert not mcap_io.starts_with_header("float64 x\nstd_msgs/Header header\n")


def test_written_file_reads_back_with_times_metadata_and_decoding(tmp_path):
    path = write_sample(tmp_path / "run.mcap")
    topics = mcap_io.topics(path)
    assert {t: i.message_count for t, i in topics.items()} == {
        "/rig/measurement": 50, "/setpoints": 1, "/note": 1}
    assert topics["/setpoints"].offers == (LATCHED,)
    assert mcap_io.time_range_ns(path) == (T0_NS, T0_NS + 490_000_000)

    measurements = list(mcap_io.decoded_messages(path, ["/rig/measurement"]))
    assert [d.bhp_pa for _, d in measurements] == [float(i) for i in range(50)]
    assert all(m.publish_time_ns == (100 + i) * 10**9 + 7 for i, (m, _) in
               enumerate(measurements))
    [note] = mcap_io.read_messages(path, ["/note"])
    assert note.publish_time_ns == note.log_time_ns == T0_NS + 5
    assert deserialize_message(note.data, String).data == "hi"

    with open(path, "rb") as stream:
        reader = make_reader(stream)
        header, summary = reader.get_header(), reader.get_summary()
    assert header.profile == "ros2"
    assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
    assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
    assert all("offered_qos_profiles" in c.metadata for c in summary.channels.values())
    assert summary.statistics.chunk_count >= 1

    bag = mcap_io.read_bag_metadata(path)
    assert bag["version"] == 9 and bag["storage_identifier"] == "mcap"
    assert bag["message_count"] == 52 and bag["relative_file_paths"] == ["run.mcap"]
    by_topic = {t["topic_metadata"]["name"]: t for t in bag["topics_with_message_count"]}
    assert by_topic["/rig/measurement"]["message_count"] == 50
    assert by_topic["/rig/measurement"]["topic_metadata"]["type_description_hash"] == \
        "RIHS01_test"
    assert by_topic["/setpoints"]["topic_metadata"]["offered_qos_profiles"][0][
        "durability"] == "transient_local"


def test_rosbags_reads_the_file_with_its_embedded_schemas(tmp_path):
    path = write_sample(tmp_path / "run.mcap")
    with AnyReader([path]) as reader:
        connections = [c for c in reader.connections if c.topic == "/rig/measurement"]
        values = [reader.deserialize(raw, c.msgtype).choke_dp_pa
                  for c, _, raw in reader.messages(connections=connections)]
        [setpoints] = [c for c in reader.connections if c.topic == "/setpoints"]
    assert values == [2.0 * i for i in range(50)]
    assert setpoints.ext.offered_qos_profiles[0].durability.name == "TRANSIENT_LOCAL"


def chunk_spans(path):
    """(start offset, end offset, message count) of every chunk, via the mcap library."""
    with open(path, "rb") as stream:
        indexes = make_reader(stream).get_summary().chunk_indexes
    with open(path, "rb") as stream:
        chunks = [r for r in StreamReader(stream, emit_chunks=True).records
                  if isinstance(r, Chunk)]
    return [(index.chunk_start_offset, index.chunk_start_offset + index.chunk_length,
             sum(isinstance(r, Message) for r in breakup_chunk(chunk)))
            for index, chunk in zip(indexes, chunks)]


def test_recover_returns_exactly_the_complete_chunks_of_a_truncated_file(tmp_path):
    path = write_sample(tmp_path / "full.mcap", n=200, chunk_size_bytes=1024)
    data = path.read_bytes()
    full = mcap_io.recover(path)
    assert len(full) == 202
    spans = chunk_spans(path)
    assert len(spans) >= 5
    for k in (0, 1, len(spans) // 2, len(spans) - 1):
        start, end, _ = spans[k]
        cut = tmp_path / f"cut{k}.mcap"
        cut.write_bytes(data[:(start + end) // 2])
        with pytest.raises(Exception):
            mcap_io.topics(cut)
        messages = mcap_io.recover(cut)
        assert len(messages) == sum(count for _, _, count in spans[:k])
        assert [(m.topic, m.log_time_ns) for m in messages] == \
            [(m.topic, m.log_time_ns) for m in full[:len(messages)]]
        assert all(mcap_io.decode(m) is not None for m in messages)


def test_unclosed_writer_leaves_full_chunks_on_disk(tmp_path):
    path = tmp_path / "open.mcap"
    writer = mcap_io.McapWriter(path, chunk_size_bytes=1024)
    writer.add_topic("/rig/measurement", "drill_msgs/msg/RigMeasurement", [QosOffer()])
    count = 101             # a prime: whatever a chunk holds, the last one is not full
    for i in range(count):
        writer.write("/rig/measurement", measurement(i), T0_NS + i)
    values = [mcap_io.decode(m).bhp_pa for m in mcap_io.recover(path)]
    assert count // 2 <= len(values) < count
    assert values == [float(i) for i in range(len(values))]
    assert writer.close() == {"/rig/measurement": count}
    assert len(mcap_io.recover(path)) == count


def test_write_counts_sits_next_to_the_file(tmp_path):
    out = mcap_io.write_counts(tmp_path / "run.mcap", {"/a": 3})
    assert out.name == "run.mcap.counts.json"
    assert yaml.safe_load(out.read_text()) == {"/a": 3}
