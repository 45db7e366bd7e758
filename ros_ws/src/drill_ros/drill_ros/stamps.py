"""Integer-nanosecond stamps, so lockstep keys compare exactly, and the scenario's clock."""
from builtin_interfaces.msg import Time

NS_PER_S = 1_000_000_000


def to_ns(stamp: Time) -> int:
    return stamp.sec * NS_PER_S + stamp.nanosec


def from_ns(ns: int) -> Time:
    return Time(sec=ns // NS_PER_S, nanosec=ns % NS_PER_S)


def seconds_to_ns(seconds: float) -> int:
    return int(round(seconds * NS_PER_S))


class ScenarioClock:
    """Scenario time, the clock of a scenario's events and operator actions: seconds from
    the stamp of the first measurement (``start``; later calls keep the first)."""

    def __init__(self):
        self.start_ns: int | None = None

    def start(self, stamp_ns: int) -> None:
        if self.start_ns is None:
            self.start_ns = stamp_ns

    def seconds(self, stamp_ns: int) -> float:
        """Scenario time at ``stamp_ns`` (0 before the first measurement)."""
        return 0.0 if self.start_ns is None else (stamp_ns - self.start_ns) / NS_PER_S
