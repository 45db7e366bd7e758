"""Messages held by stamp until the node's schedule needs them (fast-mode lockstep).

DDS orders messages per topic, not across topics, so a node waits for the input
stamped t_k that its schedule says is due rather than for another node's ack.
"""
from __future__ import annotations

from drill_ros.stamps import to_ns


class StampedInbox:
    """Latest-per-stamp store for several named inputs."""

    def __init__(self, names):
        self._slots = {name: {} for name in names}

    def put(self, name: str, msg) -> None:
        self._slots[name][to_ns(msg.header.stamp)] = msg

    def has(self, name: str, stamp_ns: int) -> bool:
        return stamp_ns in self._slots[name]

    def passed(self, name: str, stamp_ns: int) -> bool:
        """Whether ``name`` has a message newer than ``stamp_ns`` but none stamped
        ``stamp_ns``: on a reliable topic, which delivers in order, that one is lost (it was
        published before the subscription matched)."""
        slot = self._slots[name]
        return stamp_ns not in slot and any(s > stamp_ns for s in slot)

    def ready(self, stamp_ns: int, names=None) -> bool:
        return all(stamp_ns in self._slots[n] for n in (self._slots if names is None else names))

    def take(self, name: str, stamp_ns: int):
        """Remove and return the message of ``name`` stamped ``stamp_ns``; drop older ones."""
        slot = self._slots[name]
        msg = slot.pop(stamp_ns)
        for old in [s for s in slot if s < stamp_ns]:
            del slot[old]
        return msg

    def latest(self, name: str):
        """Most recent message of ``name`` (realtime mode), or None."""
        slot = self._slots[name]
        return slot[max(slot)] if slot else None
