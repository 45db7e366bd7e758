"""A measurement stamped t_k paired with the rig floor's step for the frame before it,
t_k - dt (the step the plant ran under up to t_k), in stamp order, whichever of the two
streams comes first. The protection node and the trip sheet's feed each keep one."""
from __future__ import annotations


class FramePairs:
    """``item`` (a measurement) and ``partner`` (a floor step) stamped in ns, in any order;
    each returns the items now released, in stamp order, as (stamp, item, partner): the
    partner stamped one frame before the item, or None where none will come (the first
    frame has none before it; a later partner has already come)."""

    def __init__(self, frame_ns: int):
        self.frame_ns = frame_ns
        self._items: dict[int, object] = {}
        self._partners: dict[int, object] = {}
        self._latest_partner_ns: int | None = None

    def item(self, stamp_ns: int, item) -> list[tuple[int, object, object | None]]:
        self._items[stamp_ns] = item
        return self._release()

    def partner(self, stamp_ns: int, partner) -> list[tuple[int, object, object | None]]:
        self._partners[stamp_ns] = partner
        if self._latest_partner_ns is None or stamp_ns > self._latest_partner_ns:
            self._latest_partner_ns = stamp_ns
        return self._release()

    def waiting(self) -> int:
        """How many items wait for their partner."""
        return len(self._items)

    def _release(self) -> list[tuple[int, object, object | None]]:
        released = []
        while self._items:
            stamp = min(self._items)
            before = stamp - self.frame_ns
            if before in self._partners:
                partner = self._partners.pop(before)
            elif before < 0 or (self._latest_partner_ns is not None
                                and self._latest_partner_ns >= before):
                partner = None
            else:
                break                               # its partner may still come
            released.append((stamp, self._items.pop(stamp), partner))
            for older in [s for s in self._partners if s < before]:
                del self._partners[older]
        return released
