"""Ends a host's share of a split run (docs/multihost.md) once the run's finishing nodes
that run on other hosts (the plant; in fast mode the estimator) have ended: each is
watched on a topic only it publishes, and counts as ended once its publisher, seen in the
graph, is gone. Exits with code 0 then. It makes no endpoints on the rig's topics, so the
plant's wait list and the first-publish gates do not count it.

    python -m drill_bringup.finish_watch TOPIC [TOPIC ...]
"""
from __future__ import annotations

import sys
import time
from collections.abc import Iterable, Mapping

POLL_S = 0.2


def all_ended(samples: Iterable[Mapping[str, int]]) -> bool:
    """Whether a series of publisher counts per topic shows every topic's publisher come
    and go (a topic whose publisher has gone stays ended). False if the series runs out
    first."""
    seen: set[str] = set()
    gone: set[str] = set()
    for counts in samples:
        for topic, count in counts.items():
            if count > 0:
                seen.add(topic)
            elif topic in seen:
                gone.add(topic)
        if counts and gone >= set(counts):
            return True
    return False


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if not args or any(not topic.startswith("/") for topic in args):
        print(f"finish_watch: topics must be absolute names, given {args}\n{__doc__}",
              file=sys.stderr)
        return 2
    import rclpy
    from rclpy.signals import SignalHandlerOptions
    from drill_ros.runner import shut_down

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("finish_watch", start_parameter_services=False)

    def samples():
        while True:
            yield {topic: node.count_publishers(topic) for topic in args}
            time.sleep(POLL_S)
    try:
        all_ended(samples())
        node.get_logger().info(f"the publishers of {', '.join(args)} are gone: the run has ended")
    except KeyboardInterrupt:
        return 130
    finally:
        shut_down(None, node)
    return 0


if __name__ == "__main__":
    sys.exit(main())
