"""In-process delivery between the nodes of one container (rclpy has no intra-process
communication of its own).

A subscription is local when every publisher of its topic in the run lives in the same
process and the topic is reliable (not latched: a latched value must also reach a reader
that comes late). A local subscription is not created in the middleware at all; the
publishers of its topic still publish to DDS for the other processes (the recorder, the
estimator) and hand each message to this bus, which queues a shallow copy of it (its
fields, not their contents: a publisher may assign new values to a message it publishes
again, but must not change a published array or nested message in place, the rule of a
shared message under rclcpp's intra-process delivery too). The container
delivers the queue between executor spins, so a callback never runs inside another's
publish, and every message is taken in the order it was published.

A reliable topic published outside the process that several nodes here subscribe to is
taken once: the first node's subscription is made in the middleware and hands each
message to every subscriber here, in the order they subscribed (the others get shallow
copies, as above). Each take costs the executor a wait-set pass, a DDS take and a
deserialisation, so this saves one per message and extra subscriber; the graph counts
one middleware subscription per process for such a topic (graph.local_subscriptions).
"""
from __future__ import annotations

import copy
from collections import defaultdict, deque


def _shallow_copy(msg):
    """A new message holding the same field values (ROS messages keep their fields in
    __slots__)."""
    slots = getattr(type(msg), "__slots__", None)
    if slots is None:
        return copy.copy(msg)
    new = type(msg).__new__(type(msg))
    for slot in slots:
        setattr(new, slot, getattr(msg, slot))
    return new


class LocalBus:
    """Local subscriptions by topic and the queue of messages for them."""

    def __init__(self, local_topics):
        self.local_topics = frozenset(local_topics)
        self._subscribers: dict[str, list] = defaultdict(list)
        self._shared: dict[str, list] = {}
        self._queue: deque = deque()

    def subscribe(self, topic: str, callback) -> bool:
        """Take ``topic`` locally if it is local here; False: subscribe in the middleware."""
        if topic not in self.local_topics:
            return False
        self._subscribers[topic].append(callback)
        return True

    def share(self, topic: str, callback, create):
        """Take ``topic`` (reliable, published elsewhere) with the process's one middleware
        subscription to it: the first caller's ``create(fan_out)`` makes it and is returned;
        a later caller's ``callback`` joins it and gets None."""
        callbacks = self._shared.get(topic)
        if callbacks is not None:
            callbacks.append(callback)
            return None
        callbacks = self._shared[topic] = [callback]

        def fan_out(msg):
            callbacks[0](msg)
            for other in callbacks[1:]:
                other(_shallow_copy(msg))
        return create(fan_out)

    def publish(self, topic: str, msg) -> None:
        """Queue a shallow copy of ``msg`` for each local subscriber of ``topic``."""
        for callback in self._subscribers.get(topic, ()):
            self._queue.append((callback, _shallow_copy(msg)))

    @property
    def pending(self) -> bool:
        return bool(self._queue)

    def deliver(self) -> int:
        """Run the callbacks of the queued messages (and of those they publish); returns
        how many ran."""
        count = 0
        while self._queue:
            callback, msg = self._queue.popleft()
            callback(msg)
            count += 1
        return count
