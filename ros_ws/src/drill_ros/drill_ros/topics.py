"""Topic and service names (drill_ros.topic_names) and their QoS (docs/design.md §2).

Everything the fast-mode lockstep depends on, and everything recorded, is reliable
with keep-all history; setpoints are latched (transient local, depth 1).
"""
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from drill_ros.topic_names import *  # noqa: F401,F403  (the names, defined there)

# Discovery precedes endpoint matching: a pause for reliable matches to complete once the
# graph shows the endpoints. In fast mode every first message on a reliable topic also
# waits until its publisher has matched its readers (graph.first_publish_matches), so
# this only covers a reader that has not yet matched a publisher that matched it.
MATCH_SETTLE_S = 0.5

RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)
LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
EVENT_LOG_DEPTH = 1000      # events a publisher keeps for a reader that matches it late
# The event topics: reliable, and transient local so that a reader DDS matches late (the
# recorder while a busy machine is still discovering, a console opened mid-run) still
# gets every event published before that from the publisher's history.
EVENT_LOG = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=EVENT_LOG_DEPTH,
                       reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
