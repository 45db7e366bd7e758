"""The stamped inbox of the fast-mode lockstep: what is due, and what is lost."""
from types import SimpleNamespace

from drill_ros.inbox import StampedInbox


def msg(stamp_ns):
    return SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(
        sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)))


def test_a_message_passed_by_a_later_one_is_lost_and_the_rest_still_waited_for():
    box = StampedInbox(("a", "b"))
    box.put("a", msg(100))
    assert not box.ready(0) and not box.passed("b", 0)       # nothing on b: still coming
    assert box.passed("a", 0) and box.passed("a", 50)         # 100 came, 0 and 50 never will
    assert not box.passed("a", 100) and not box.passed("a", 150)
    box.put("b", msg(0))
    assert box.ready(0, ["b"]) and box.ready(100, []) and not box.ready(100)
    assert box.take("b", 0).header.stamp.nanosec == 0 and not box.has("b", 0)
