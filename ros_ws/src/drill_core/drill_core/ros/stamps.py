"""Integer-nanosecond stamps, so lockstep keys compare exactly."""
from builtin_interfaces.msg import Time

NS_PER_S = 1_000_000_000


def to_ns(stamp: Time) -> int:
    return stamp.sec * NS_PER_S + stamp.nanosec


def from_ns(ns: int) -> Time:
    return Time(sec=ns // NS_PER_S, nanosec=ns % NS_PER_S)


def seconds_to_ns(seconds: float) -> int:
    return int(round(seconds * NS_PER_S))
