"""Helper process for test_dds_foundation: publish or receive drill_msgs/RigMeasurement.

    python dds_measurements.py pub TOPIC N      # publisher
    python dds_measurements.py sub TOPIC N      # subscriber

Both use reliable, keep-all, volatile QoS. Handshake over stdio so no sample can be
sent before both ends have matched:
  * each side prints ``MATCHED`` once it sees the other end on the topic;
  * the publisher then waits for a line ``go`` on stdin, publishes N samples
    (values from :func:`sample_values`), waits until all are acknowledged and prints
    ``SENT <n> acked=<bool>``;
  * the subscriber prints one JSON line ``{"received": [...]}`` with the decoded
    fields of every sample once it has N of them (or when its deadline passes).
Every wait has a deadline (``RIG_TEST_TIMEOUT_S``, default 20 s): a hang exits non-zero.
Before its ROS teardown each side prints ``EXIT <code>``; the teardown runs under
:func:`teardown.arm_watchdog` (a stuck one dumps its stacks and ends the process).
"""
from __future__ import annotations

import json
import math
import os
import sys
import time

TIMEOUT_S = float(os.environ.get("RIG_TEST_TIMEOUT_S", "20"))


def sample_values(i: int) -> dict:
    """The fields of sample ``i`` (also computed by the test to check what arrived)."""
    valid = i % 5 != 0
    return {
        "stamp_sec": 1000 + i,
        "stamp_nanosec": 10_000_000 * (i % 100),
        "frame_id": "rig",
        "block_position_m": 0.123456789 + 0.1 * i,
        "choke_dp_pa": 2.5e5 + 1.25 * i,
        "bhp_pa": 3.1e7 - 17.5 * i,
        "string_flow_m3s": 1.6667e-3 * (1 + i) if valid else math.nan,
        "string_flow_valid": valid,
    }


def decoded(msg) -> dict:
    return {
        "stamp_sec": msg.header.stamp.sec,
        "stamp_nanosec": msg.header.stamp.nanosec,
        "frame_id": msg.header.frame_id,
        "block_position_m": msg.block_position_m,
        "choke_dp_pa": msg.choke_dp_pa,
        "bhp_pa": msg.bhp_pa,
        "string_flow_m3s": msg.string_flow_m3s,
        "string_flow_valid": msg.string_flow_valid,
    }


def say(text: str) -> None:
    print(text, flush=True)


def main(argv: list[str]) -> int:
    code = run(argv)
    say(f"EXIT {code}")
    return code


def run(argv: list[str]) -> int:
    role, topic, count = argv[1], argv[2], int(argv[3])
    import rclpy
    from rclpy.duration import Duration
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from drill_msgs.msg import RigMeasurement
    from drill_ros.runner import shut_down
    from teardown import arm_watchdog

    qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.VOLATILE)
    rclpy.init(args=[])
    node = rclpy.create_node(f"test_dds_{role}")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    deadline = time.monotonic() + TIMEOUT_S
    try:
        if role == "pub":
            pub = node.create_publisher(RigMeasurement, topic, qos)
            while pub.get_subscription_count() < 1:
                if time.monotonic() > deadline:
                    say("TIMEOUT waiting for a subscriber")
                    return 2
                time.sleep(0.02)
            say("MATCHED")
            if sys.stdin.readline().strip() != "go":
                say("no go")
                return 3
            for i in range(count):
                values = sample_values(i)
                msg = RigMeasurement()
                msg.header.stamp.sec = values["stamp_sec"]
                msg.header.stamp.nanosec = values["stamp_nanosec"]
                msg.header.frame_id = values["frame_id"]
                msg.block_position_m = values["block_position_m"]
                msg.choke_dp_pa = values["choke_dp_pa"]
                msg.bhp_pa = values["bhp_pa"]
                msg.string_flow_m3s = values["string_flow_m3s"]
                msg.string_flow_valid = values["string_flow_valid"]
                pub.publish(msg)
            acked = pub.wait_for_all_acked(Duration(seconds=max(1.0, deadline - time.monotonic())))
            say(f"SENT {count} acked={acked}")
            return 0 if acked else 4
        if role == "sub":
            received: list[dict] = []
            sub = node.create_subscription(RigMeasurement, topic,
                                           lambda msg: received.append(decoded(msg)), qos)
            matched = False
            while len(received) < count and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
                if not matched and sub.get_publisher_count() >= 1:
                    matched = True
                    say("MATCHED")
            say(json.dumps({"received": received}))   # NaN is written as NaN (Python json)
            return 0 if len(received) == count else 5
        raise SystemExit(f"unknown role {role!r}")
    finally:
        arm_watchdog()
        shut_down(executor, node)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
