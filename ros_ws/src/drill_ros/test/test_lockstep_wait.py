"""What the plant still waits for before t_0 (drill_ros.lockstep.missing_endpoints),
on a stand-in for the node's graph counts: what it logs while a split run's other host has
not come."""
from drill_ros.lockstep import missing_endpoints


class Graph:
    def __init__(self, subscribers: dict, publishers: dict):
        self.subscribers, self.publishers = subscribers, publishers

    def count_subscribers(self, topic: str) -> int:
        return self.subscribers.get(topic, 0)

    def count_publishers(self, topic: str) -> int:
        return self.publishers.get(topic, 0)


WAIT_FOR = ["sub@/rig/measurement:7", "pub@/estimator/estimate:1", "/clock:1", ""]


def test_the_unmet_endpoints_are_named_with_the_count_seen():
    graph = Graph({"/rig/measurement": 5, "/clock": 1}, {})
    assert missing_endpoints(graph, WAIT_FOR) == ["sub@/rig/measurement:7 (seen 5)",
                                                  "pub@/estimator/estimate:1 (seen 0)"]


def test_nothing_is_missing_once_every_count_is_met_or_passed():
    graph = Graph({"/rig/measurement": 8, "/clock": 1}, {"/estimator/estimate": 1})
    assert missing_endpoints(graph, WAIT_FOR) == []
    bare = Graph({"/clock": 0}, {"/clock": 3})           # a bare topic:N counts subscriptions
    assert missing_endpoints(bare, ["/clock:1"]) == ["/clock:1 (seen 0)"]
