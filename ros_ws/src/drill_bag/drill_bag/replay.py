"""Replay an MCAP recording by republishing its raw CDR messages (rosbag2-style options).

Run: python -m drill_bag.replay FILE [--rate F] [--loop] [--topics T ...] [--regex R]
     [--exclude-regex R] [--start-offset S] [--clock [HZ]] [--remap OLD:=NEW ...] [--delay S]
     [--wait-for-subscribers]
"""
import argparse
import re
import signal
import sys
import threading
import time
from dataclasses import dataclass
from collections.abc import Iterable, Sequence

import rclpy
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile,
                       ReliabilityPolicy)
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time
from rosgraph_msgs.msg import Clock

from drill_ros.runner import shut_down

from drill_bag import mcap_io
from drill_bag.mcap_io import QosOffer, RecordedMessage

CLOCK_TOPIC = "/clock"
DEFAULT_CLOCK_HZ = 100.0
VOLATILE_DEPTH = 100
LATCHED_DEPTH = 1
ACK_TIMEOUT_S = 5.0
MAX_SLEEP_S = 0.1
SUBSCRIBER_POLL_S = 0.05
NS_PER_S = 1e9


# ---------------------------------------------------------------- pure helpers

def select_topics(names: Iterable[str], topics: Sequence[str] | None = None,
                  regex: str | None = None, exclude_regex: str | None = None) -> list[str]:
    """Topics to replay: listed or regex-matched (all if neither given), minus excluded."""
    def chosen(name: str) -> bool:
        listed = topics is not None and name in topics
        matched = bool(regex) and re.search(regex, name) is not None
        excluded = bool(exclude_regex) and re.search(exclude_regex, name) is not None
        return (listed or matched or (topics is None and regex is None)) and not excluded
    return sorted(name for name in names if chosen(name))


def split_ros_args(argv: Sequence[str]) -> tuple[list[str], list[str]]:
    """argv -> (tool arguments, ROS arguments between --ros-args and -- or the end)."""
    tool, ros, in_ros = [], [], False
    for arg in argv:
        if arg == "--ros-args":
            in_ros = True
        elif in_ros and arg == "--":
            in_ros = False
            continue
        (ros if in_ros else tool).append(arg)
    return tool, ros


def parse_remaps(items: Iterable[str]) -> dict[str, str]:
    """['old:=new', ...] -> {'old': 'new', ...}."""
    remaps = {}
    for item in items:
        old, sep, new = item.partition(":=")
        if not (sep and old and new):
            raise ValueError(f"remap must look like old:=new, got {item!r}")
        remaps[old] = new
    return remaps


def replay_offer(offers: Sequence[QosOffer]) -> QosOffer:
    """The offer to republish with: the recorded one if all publishers agreed, else default."""
    def key(o: QosOffer):
        return (o.reliability, o.durability, o.deadline_ns, o.liveliness,
                o.liveliness_lease_duration_ns)
    if offers and all(key(o) == key(offers[0]) for o in offers):
        return offers[0]
    return QosOffer()


def _policy(enum, value: int, fallback):
    """enum(value) for a concrete policy; fallback for system default, unknown, best available."""
    try:
        policy = enum(value)
    except ValueError:
        return fallback
    return fallback if policy.name in ("SYSTEM_DEFAULT", "UNKNOWN", "BEST_AVAILABLE") else policy


def publisher_qos(offers: Sequence[QosOffer]) -> QoSProfile:
    """rclpy QoS from recorded offers: transient local keep-last at the offered depth for
    latched topics and event logs, keep-all for reliable ones (a slow reader, e.g. a
    lockstep node, must not lose a sample), else keep-last."""
    offer = replay_offer(offers)
    latched = offer.durability == mcap_io.TRANSIENT_LOCAL
    reliability = _policy(ReliabilityPolicy, offer.reliability, ReliabilityPolicy.RELIABLE)
    lossless = not latched and reliability == ReliabilityPolicy.RELIABLE
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL if lossless else HistoryPolicy.KEEP_LAST,
        depth=max(offer.depth, LATCHED_DEPTH) if latched else VOLATILE_DEPTH,
        reliability=reliability,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
        deadline=Duration(nanoseconds=offer.deadline_ns),
        lifespan=Duration(nanoseconds=offer.lifespan_ns),
        liveliness=_policy(LivelinessPolicy, offer.liveliness, LivelinessPolicy.SYSTEM_DEFAULT),
        liveliness_lease_duration=Duration(nanoseconds=offer.liveliness_lease_duration_ns),
        avoid_ros_namespace_conventions=offer.avoid_ros_namespace_conventions)


def latest_per_topic(messages: Iterable[RecordedMessage]) -> list[RecordedMessage]:
    """The last message of each topic, in log-time order."""
    latest = {m.topic: m for m in messages}
    return sorted(latest.values(), key=lambda m: m.log_time_ns)


@dataclass(frozen=True)
class Timebase:
    """Maps recording log time to wall (monotonic) time at a rate factor."""

    recording_start_ns: int
    wall_start_s: float
    rate: float

    def to_wall_s(self, log_time_ns: int) -> float:
        """Wall time at which a message of this log time is due."""
        return self.wall_start_s + (log_time_ns - self.recording_start_ns) / NS_PER_S / self.rate

    def to_recording_ns(self, wall_s: float) -> int:
        """Recording time corresponding to a wall time."""
        return self.recording_start_ns + int((wall_s - self.wall_start_s) * self.rate * NS_PER_S)


# ---------------------------------------------------------------- shell

class Pacer:
    """Sleeps until messages are due, publishing /clock at clock_hz (wall) meanwhile."""

    def __init__(self, clock_publisher, clock_hz: float, stop: threading.Event):
        self._publisher = clock_publisher
        self._period_s = 1.0 / clock_hz if clock_publisher else None
        self._stop = stop
        self._timebase: Timebase | None = None
        self._next_tick_s = 0.0

    def start(self, timebase: Timebase) -> None:
        """Begin a pass over the recording."""
        self._timebase = timebase
        self._next_tick_s = timebase.wall_start_s

    def wait_until(self, wall_s: float) -> bool:
        """Sleep until wall_s; False if stopped first."""
        while not self._stop.is_set():
            now_s = time.monotonic()
            if self._period_s and now_s >= self._next_tick_s:
                self._tick(now_s)
            if now_s >= wall_s:
                return True
            wake_s = min(wall_s, now_s + MAX_SLEEP_S)
            if self._period_s:
                wake_s = min(wake_s, self._next_tick_s)
            time.sleep(max(wake_s - now_s, 0.0))
        return False

    def _tick(self, now_s: float) -> None:
        msg = Clock()
        msg.clock = Time(nanoseconds=self._timebase.to_recording_ns(now_s)).to_msg()
        self._publisher.publish(msg)
        self._next_tick_s = max(self._next_tick_s + self._period_s, now_s)


def _play_once(path, publishers: dict[str, object], latched: list[str], start_ns: int,
               rate: float, pacer: Pacer) -> int:
    """One pass: latched backlog before start_ns at once, then the rest in time."""
    backlog = []
    if latched:
        backlog = latest_per_topic(mcap_io.read_messages(path, latched, end_ns=start_ns))
    for message in backlog:
        publishers[message.topic].publish(message.data)
    timebase = Timebase(start_ns, time.monotonic(), rate)
    pacer.start(timebase)
    count = len(backlog)
    for message in mcap_io.read_messages(path, list(publishers), start_ns=start_ns):
        if not pacer.wait_until(timebase.to_wall_s(message.log_time_ns)):
            break
        publishers[message.topic].publish(message.data)
        count += 1
    return count


def _wait_for_subscribers(publishers, stop: threading.Event) -> None:
    while not stop.is_set() and any(
            p is not None and p.get_subscription_count() == 0 for p in publishers):
        stop.wait(SUBSCRIBER_POLL_S)


def replay_file(path, *, rate: float = 1.0, loop: bool = False,
                topics: Sequence[str] | None = None, regex: str | None = None,
                exclude_regex: str | None = None, start_offset_s: float = 0.0,
                clock_hz: float = 0.0, remap: dict[str, str] | None = None,
                delay_s: float = 0.5, wait_for_subscribers: bool = False,
                node: Node | None = None, stop: threading.Event | None = None) -> int:
    """Republish a recording; returns the number of messages published.

    Needs an initialised rclpy context (a node named 'replay' is made if none is given).
    delay_s lets subscribers discover the new publishers before the first message;
    wait_for_subscribers first waits until every publisher (and /clock) has a subscriber.
    With clock_hz > 0 a recorded /clock topic is not replayed (the player owns /clock).
    """
    if rate <= 0:
        raise ValueError("rate must be positive")
    infos = mcap_io.topics(path)
    names = [n for n in select_topics(infos, topics, regex, exclude_regex)
             if not (clock_hz > 0 and n == CLOCK_TOPIC)]
    own_node = node is None
    node = Node("replay") if own_node else node
    stop = stop or threading.Event()
    remap = remap or {}
    publishers = {name: node.create_publisher(
        mcap_io.message_class(infos[name].type_name), remap.get(name, name),
        publisher_qos(infos[name].offers)) for name in names}
    clock_publisher = node.create_publisher(Clock, CLOCK_TOPIC, 10) if clock_hz > 0 else None
    pacer = Pacer(clock_publisher, clock_hz, stop)
    latched = [n for n in names if mcap_io.is_latched(infos[n].offers)]
    start_ns = mcap_io.time_range_ns(path)[0] + int(start_offset_s * NS_PER_S)
    count = 0
    try:
        if wait_for_subscribers:
            _wait_for_subscribers([*publishers.values(), clock_publisher], stop)
        stop.wait(delay_s)
        while not stop.is_set():
            played = _play_once(path, publishers, latched, start_ns, rate, pacer)
            count += played
            if not (loop and played):
                break
        for publisher in publishers.values():
            publisher.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT_S))
    finally:
        for publisher in [*publishers.values(), clock_publisher]:
            if publisher is not None:
                node.destroy_publisher(publisher)
        if own_node:
            node.destroy_node()
    return count


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """Tool command line (without the program name and ROS arguments)."""
    parser = argparse.ArgumentParser(prog="python -m drill_bag.replay",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("file", help="MCAP file")
    parser.add_argument("--rate", type=float, default=1.0, help="playback rate factor")
    parser.add_argument("--loop", action="store_true", help="replay until interrupted")
    parser.add_argument("--topics", nargs="+", help="topics to replay")
    parser.add_argument("--regex", help="also replay topics matching this regex")
    parser.add_argument("--exclude-regex", help="do not replay topics matching this regex")
    parser.add_argument("--start-offset", type=float, default=0.0, metavar="SECONDS",
                        help="skip the first SECONDS (latched topics still get their last "
                             "skipped message)")
    parser.add_argument("--clock", type=float, nargs="?", const=DEFAULT_CLOCK_HZ, default=0.0,
                        metavar="HZ", help="publish /clock at HZ (default when given: "
                                           f"{DEFAULT_CLOCK_HZ:g}; 0 = off)")
    parser.add_argument("--remap", nargs="+", default=[], metavar="OLD:=NEW",
                        help="publish topic OLD as NEW")
    parser.add_argument("--delay", type=float, default=0.5, metavar="SECONDS",
                        help="wait for discovery before the first message")
    parser.add_argument("--wait-for-subscribers", action="store_true",
                        help="before the delay, wait until every replayed topic (and /clock) "
                             "has a subscriber")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """CLI entry point; SIGINT/SIGTERM stop the replay and exit 0."""
    tool_args, ros_args = split_ros_args(sys.argv if argv is None else argv)
    args = parse_args(tool_args[1:])
    rclpy.init(args=tool_args[:1] + ros_args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    node = Node("replay")
    try:
        count = replay_file(args.file, rate=args.rate, loop=args.loop, topics=args.topics,
                            regex=args.regex, exclude_regex=args.exclude_regex,
                            start_offset_s=args.start_offset, clock_hz=args.clock,
                            remap=parse_remaps(args.remap), delay_s=args.delay,
                            wait_for_subscribers=args.wait_for_subscribers, node=node,
                            stop=stop)
        node.get_logger().info(f"replayed {count} messages from {args.file}")
    finally:
        shut_down(None, node)
    return 0


if __name__ == "__main__":
    sys.exit(main())
