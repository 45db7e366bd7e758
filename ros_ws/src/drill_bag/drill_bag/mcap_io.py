"""MCAP files in the rosbag2 "ros2" profile: definitions, QoS metadata, writer, readers.

Plain Python (no rclpy): the recorder and the replay tool are thin rclpy shells around it.
"""
import functools
import importlib
import json
import os
import re
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path
from collections.abc import Callable, Iterable, Iterator, Sequence

import yaml
import zstandard
from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer
from mcap_ros2.decoder import DecoderFactory

PROFILE = "ros2"
SCHEMA_ENCODING = "ros2msg"
MESSAGE_ENCODING = "cdr"
DELIMITER = "=" * 80
METADATA_NAME = "rosbag2"
METADATA_KEY = "serialized_metadata"
TRUTH_METADATA = "rig_truth"     # the run's plant mismatch (drill_core.mismatch file, JSON)
BAG_METADATA_VERSION = 9
DEFAULT_CHUNK_SIZE_BYTES = 1024 * 1024
INFINITE_NS = 2**63 - 1
NS_PER_S = 1_000_000_000
LIBRARY = "drill_bag.mcap_io"

PRIMITIVE_TYPES = frozenset({
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
    "int32", "uint32", "int64", "uint64", "string", "wstring",
})
HEADER_TYPES = frozenset({"std_msgs/Header", "std_msgs/msg/Header"})

HISTORY_NAMES = {0: "system_default", 1: "keep_last", 2: "keep_all", 3: "unknown"}
RELIABILITY_NAMES = {0: "system_default", 1: "reliable", 2: "best_effort", 3: "unknown",
                     4: "best_available"}
DURABILITY_NAMES = {0: "system_default", 1: "transient_local", 2: "volatile", 3: "unknown",
                    4: "best_available"}
LIVELINESS_NAMES = {0: "system_default", 1: "automatic", 3: "manual_by_topic", 4: "unknown",
                    5: "best_available"}
RELIABLE, BEST_EFFORT = 1, 2
TRANSIENT_LOCAL, VOLATILE = 1, 2

COMPRESSION = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
               "none": CompressionType.NONE}
TORN_FILE_ERRORS = (McapError, struct.error, ValueError, RuntimeError, zstandard.ZstdError)


# ---------------------------------------------------------------- type names and definitions

def split_type_name(type_name: str) -> tuple[str, str, str]:
    """'pkg/msg/Type' or 'pkg/Type' -> (pkg, 'msg', Type)."""
    parts = type_name.split("/")
    if len(parts) == 2:
        return parts[0], "msg", parts[1]
    if len(parts) == 3:
        return parts[0], parts[1], parts[2]
    raise ValueError(f"not a ROS type name: {type_name!r}")


def share_directory(package: str) -> Path:
    """Share directory of an ament package; falls back to this interpreter's prefix.

    The venv holding the ROS wheels is an ament prefix too, but it is not always on
    AMENT_PREFIX_PATH.
    """
    try:
        return Path(get_package_share_directory(package))
    except PackageNotFoundError:
        candidate = Path(sys.prefix) / "share" / package
        if candidate.is_dir():
            return candidate
        raise


def msg_text(package: str, name: str) -> str:
    """Text of the installed pkg/msg/Name.msg file."""
    return (share_directory(package) / "msg" / f"{name}.msg").read_text()


def field_types(text: str) -> list[str]:
    """Field (and constant) types of a .msg text, without array or bound suffixes."""
    types = []
    for line in text.splitlines():
        code = line.split("#", 1)[0].strip()
        if code:
            types.append(re.split(r"[\[<]", code.split()[0], maxsplit=1)[0])
    return types


def dependencies(text: str, package: str) -> list[str]:
    """Sorted non-primitive types a .msg text uses, as 'pkg/Type'."""
    deps = set()
    for type_name in field_types(text):
        if type_name in PRIMITIVE_TYPES:
            continue
        if "/" not in type_name:
            type_name = f"{package}/{type_name}"
        pkg, _, name = split_type_name(type_name)
        deps.add(f"{pkg}/{name}")
    return sorted(deps)


def message_definition(type_name: str,
                       load: Callable[[str, str], str] = msg_text) -> str:
    """Dependency-expanded ros2msg definition, as rosbag2 writes it into MCAP schemas."""
    seen = set()

    def expand(package: str, name: str) -> str:
        text = load(package, name)
        for dep in dependencies(text, package):
            if dep not in seen:
                seen.add(dep)
                dep_package, _, dep_name = split_type_name(dep)
                text += f"\n{DELIMITER}\nMSG: {dep}\n" + expand(dep_package, dep_name)
        return text

    package, _, name = split_type_name(type_name)
    return expand(package, name)


def starts_with_header(text: str) -> bool:
    """True when the first field of a .msg text is a std_msgs/Header."""
    types = field_types(text)
    return bool(types) and types[0] in HEADER_TYPES


def message_class(type_name: str) -> type:
    """Generated Python class of a ROS interface type ('pkg/msg/Type')."""
    package, kind, name = split_type_name(type_name)
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


def header_stamp_ns(cdr: bytes) -> int | None:
    """Stamp of a leading std_msgs/Header in a CDR message, None if it cannot be one."""
    if len(cdr) < 12:
        return None
    order = "<" if cdr[1] & 1 else ">"
    sec, nanosec = struct.unpack_from(order + "iI", cdr, 4)
    return sec * NS_PER_S + nanosec if sec >= 0 else None


# ---------------------------------------------------------------- QoS metadata

@dataclass(frozen=True)
class QosOffer:
    """One offered QoS profile; policies are rmw enum values, durations in ns."""

    history: int = 1
    depth: int = 10
    reliability: int = RELIABLE
    durability: int = VOLATILE
    deadline_ns: int = 0
    lifespan_ns: int = 0
    liveliness: int = 0
    liveliness_lease_duration_ns: int = 0
    avoid_ros_namespace_conventions: bool = False


def _time_dict(duration_ns: int) -> dict[str, int]:
    sec, nsec = divmod(min(duration_ns, INFINITE_NS), NS_PER_S)
    return {"sec": sec, "nsec": nsec}


def _time_ns(node: dict[str, int]) -> int:
    return min(int(node["sec"]) * NS_PER_S + int(node["nsec"]), INFINITE_NS)


def _policy_value(value, names: dict[int, str]) -> int:
    if isinstance(value, int):
        return value
    by_name = {name: number for number, name in names.items()}
    return by_name.get(str(value).lower(), by_name["unknown"])


def qos_to_dict(offer: QosOffer) -> dict:
    """A QoS profile as rosbag2 (metadata version 9, Jazzy) serialises it."""
    return {
        "history": HISTORY_NAMES.get(offer.history, "unknown"),
        "depth": offer.depth,
        "reliability": RELIABILITY_NAMES.get(offer.reliability, "unknown"),
        "durability": DURABILITY_NAMES.get(offer.durability, "unknown"),
        "deadline": _time_dict(offer.deadline_ns),
        "lifespan": _time_dict(offer.lifespan_ns),
        "liveliness": LIVELINESS_NAMES.get(offer.liveliness, "unknown"),
        "liveliness_lease_duration": _time_dict(offer.liveliness_lease_duration_ns),
        "avoid_ros_namespace_conventions": offer.avoid_ros_namespace_conventions,
    }


def qos_from_dict(node: dict) -> QosOffer:
    """Inverse of qos_to_dict; also reads the integer policies of older bags."""
    return QosOffer(
        history=_policy_value(node["history"], HISTORY_NAMES),
        depth=int(node["depth"]),
        reliability=_policy_value(node["reliability"], RELIABILITY_NAMES),
        durability=_policy_value(node["durability"], DURABILITY_NAMES),
        deadline_ns=_time_ns(node["deadline"]),
        lifespan_ns=_time_ns(node["lifespan"]),
        liveliness=_policy_value(node["liveliness"], LIVELINESS_NAMES),
        liveliness_lease_duration_ns=_time_ns(node["liveliness_lease_duration"]),
        avoid_ros_namespace_conventions=bool(node["avoid_ros_namespace_conventions"]),
    )


def offered_qos_yaml(offers: Iterable[QosOffer]) -> str:
    """Channel metadata value 'offered_qos_profiles' (a YAML list)."""
    return yaml.safe_dump([qos_to_dict(o) for o in offers], sort_keys=False,
                          default_flow_style=False)


def parse_offered_qos(text: str) -> list[QosOffer]:
    """Offers from an 'offered_qos_profiles' YAML string (empty string: no offers)."""
    return [qos_from_dict(node) for node in (yaml.safe_load(text) or [])]


def is_latched(offers: Sequence[QosOffer]) -> bool:
    """True when every offer is transient local (a latched topic)."""
    return bool(offers) and all(o.durability == TRANSIENT_LOCAL for o in offers)


# ---------------------------------------------------------------- rosbag2 bag metadata

@dataclass
class TopicRecord:
    """A recorded topic and its running message count."""

    name: str
    type_name: str
    offers: tuple[QosOffer, ...]
    type_hash: str
    channel_id: int
    has_header: bool
    message_count: int = 0


def bag_metadata(file_name: str, topics: Sequence[TopicRecord], start_ns: int, end_ns: int,
                 ros_distro: str) -> dict:
    """rosbag2 BagMetadata (version 9) of a single-file MCAP bag."""
    duration = {"nanoseconds": max(end_ns - start_ns, 0)}
    starting_time = {"nanoseconds_since_epoch": start_ns}
    total = sum(t.message_count for t in topics)
    return {
        "version": BAG_METADATA_VERSION,
        "storage_identifier": "mcap",
        "duration": duration,
        "starting_time": starting_time,
        "message_count": total,
        "topics_with_message_count": [
            {"topic_metadata": {
                "name": t.name,
                "type": t.type_name,
                "serialization_format": MESSAGE_ENCODING,
                "offered_qos_profiles": [qos_to_dict(o) for o in t.offers],
                "type_description_hash": t.type_hash,
            }, "message_count": t.message_count}
            for t in topics
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [file_name],
        "files": [{"path": file_name, "starting_time": starting_time, "duration": duration,
                   "message_count": total}],
        "custom_data": {},
        "ros_distro": ros_distro,
    }


# ---------------------------------------------------------------- writer

class _UnbufferedFile:
    """Write-through file: every record block the mcap Writer flushes reaches the OS."""

    def __init__(self, path: str):
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        self._offset_bytes = 0

    def write(self, data: bytes) -> int:
        view = memoryview(data)
        while view:
            view = view[os.write(self._fd, view):]
        self._offset_bytes += len(data)
        return len(data)

    def tell(self) -> int:
        return self._offset_bytes

    def flush(self) -> None:
        """Nothing is buffered here."""

    def close(self) -> None:
        os.close(self._fd)


class McapWriter:
    """Chunked, compressed MCAP writer in the rosbag2 ros2 profile.

    Chunks reach the file as soon as they are full, so a hard kill loses only the open chunk.
    """

    def __init__(self, path, *, chunk_size_bytes: int = DEFAULT_CHUNK_SIZE_BYTES,
                 compression: str = "zstd", ros_distro: str | None = None,
                 load: Callable[[str, str], str] = msg_text):
        self.path = Path(path)
        self._ros_distro = ros_distro or os.environ.get("ROS_DISTRO", "jazzy")
        self._load = load
        self._file = _UnbufferedFile(str(self.path))
        self._writer = Writer(self._file, chunk_size=chunk_size_bytes,
                              compression=COMPRESSION[compression])
        self._writer.start(profile=PROFILE, library=LIBRARY)
        self._schema_ids: dict[str, int] = {}
        self._topics: dict[str, TopicRecord] = {}
        self._start_ns: int | None = None
        self._end_ns = 0
        self.closed = False

    def __enter__(self):
        return self

    def __exit__(self, *_exc):
        self.close()

    def add_metadata(self, name: str, values: dict[str, str]) -> None:
        """A metadata record (name, string -> string) written now: it survives a hard kill
        once its chunk reaches the file."""
        self._writer.add_metadata(name, values)

    def add_topic(self, topic: str, type_name: str, offers: Sequence[QosOffer] = (),
                  type_hash: str = "") -> None:
        """Register a topic: schema (once per type) and channel with QoS metadata."""
        schema_id = self._schema_id(type_name)
        metadata = {"offered_qos_profiles": offered_qos_yaml(offers),
                    "topic_type_hash": type_hash}
        channel_id = self._writer.register_channel(topic, MESSAGE_ENCODING, schema_id, metadata)
        package, _, name = split_type_name(type_name)
        self._topics[topic] = TopicRecord(topic, type_name, tuple(offers), type_hash, channel_id,
                                          starts_with_header(self._load(package, name)))

    def _schema_id(self, type_name: str) -> int:
        if type_name not in self._schema_ids:
            definition = message_definition(type_name, self._load)
            self._schema_ids[type_name] = self._writer.register_schema(
                type_name, SCHEMA_ENCODING, definition.encode())
        return self._schema_ids[type_name]

    def write(self, topic: str, data: bytes, log_time_ns: int) -> None:
        """Append one CDR message; publish time is its header stamp if it has one."""
        record = self._topics[topic]
        stamp_ns = header_stamp_ns(data) if record.has_header else None
        self._writer.add_message(record.channel_id, log_time_ns, bytes(data),
                                 log_time_ns if stamp_ns is None else stamp_ns,
                                 sequence=record.message_count)
        record.message_count += 1
        self._start_ns = log_time_ns if self._start_ns is None else min(self._start_ns,
                                                                        log_time_ns)
        self._end_ns = max(self._end_ns, log_time_ns)

    @property
    def counts(self) -> dict[str, int]:
        """Messages written per topic."""
        return {name: t.message_count for name, t in self._topics.items()}

    def close(self) -> dict[str, int]:
        """Write the rosbag2 metadata record and the summary, close the file; idempotent."""
        if not self.closed:
            start_ns = self._start_ns or 0
            metadata = bag_metadata(self.path.name, list(self._topics.values()), start_ns,
                                    max(self._end_ns, start_ns), self._ros_distro)
            self._writer.add_metadata(METADATA_NAME, {
                METADATA_KEY: yaml.safe_dump(metadata, sort_keys=False)})
            self._writer.finish()
            self._file.close()
            self.closed = True
        return self.counts


def write_counts(path, counts: dict[str, int]) -> Path:
    """Write per-topic counts next to an MCAP file as '<path>.counts.json'."""
    out = Path(f"{path}.counts.json")
    out.write_text(json.dumps(counts, indent=1, sort_keys=True))
    return out


# ---------------------------------------------------------------- readers

@dataclass(frozen=True)
class RecordedMessage:
    """One message of a file, still CDR encoded."""

    topic: str
    type_name: str
    log_time_ns: int
    publish_time_ns: int
    data: bytes
    definition: str = field(repr=False)


@dataclass(frozen=True)
class TopicInfo:
    """A channel of a file."""

    name: str
    type_name: str
    offers: tuple[QosOffer, ...]
    message_count: int


def _recorded(schema: Schema, channel: Channel, message: Message) -> RecordedMessage:
    return RecordedMessage(channel.topic, schema.name, message.log_time, message.publish_time,
                           message.data, schema.data.decode())


def topics(path) -> dict[str, TopicInfo]:
    """Channels of a finished file, from its summary."""
    with open(path, "rb") as stream:
        summary = make_reader(stream).get_summary()
    counts = summary.statistics.channel_message_counts if summary.statistics else {}
    return {
        ch.topic: TopicInfo(ch.topic, summary.schemas[ch.schema_id].name,
                            tuple(parse_offered_qos(ch.metadata.get("offered_qos_profiles", ""))),
                            counts.get(ch.id, 0))
        for ch in summary.channels.values()
    }


def time_range_ns(path) -> tuple[int, int]:
    """(first, last) message log time of a finished file."""
    with open(path, "rb") as stream:
        stats = make_reader(stream).get_summary().statistics
    return stats.message_start_time, stats.message_end_time


def read_messages(path, topics: Iterable[str] | None = None,
                  start_ns: int | None = None,
                  end_ns: int | None = None) -> Iterator[RecordedMessage]:
    """Messages of a finished file in log-time order, start inclusive, end exclusive."""
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        selected = None if topics is None else list(topics)
        for schema, channel, message in reader.iter_messages(
                topics=selected, starting_at=start_ns, ending_before=end_ns):
            yield _recorded(schema, channel, message)


def read_metadata(path, name: str) -> dict[str, str] | None:
    """The metadata record ``name`` of a file, None if absent."""
    with open(path, "rb") as stream:
        for record in make_reader(stream).iter_metadata():
            if record.name == name:
                return dict(record.metadata)
    return None


def read_bag_metadata(path) -> dict | None:
    """The rosbag2 'serialized_metadata' of a finished file, None if absent."""
    with open(path, "rb") as stream:
        for record in make_reader(stream).iter_metadata():
            if record.name == METADATA_NAME:
                return yaml.safe_load(record.metadata[METADATA_KEY])
    return None


@functools.lru_cache(maxsize=None)
def _decoder(type_name: str, definition: str):
    schema = Schema(id=1, name=type_name, encoding=SCHEMA_ENCODING, data=definition.encode())
    return DecoderFactory().decoder_for(MESSAGE_ENCODING, schema)


def decode(message: RecordedMessage):
    """Decode a message with its embedded definition (mcap_ros2 dynamic types)."""
    return _decoder(message.type_name, message.definition)(message.data)


def decoded_messages(path, topics: Iterable[str] | None = None):
    """(RecordedMessage, decoded message) pairs of a finished file in log-time order."""
    for message in read_messages(path, topics):
        yield message, decode(message)


def recover(path) -> list[RecordedMessage]:
    """Messages of every complete chunk of a file, also one killed before its summary."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    messages: list[RecordedMessage] = []
    with open(path, "rb") as stream:
        records = StreamReader(stream, validate_crcs=True).records
        try:
            for record in records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Message):
                    channel = channels[record.channel_id]
                    messages.append(_recorded(schemas[channel.schema_id], channel, record))
        except TORN_FILE_ERRORS:
            pass
    return messages
