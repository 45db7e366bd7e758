"""Helper process for test_dds_foundation: a drill_msgs/srv/SetSetpoints server.

    python dds_setpoint_server.py SERVICE_NAME

Refuses a negative (or non-finite) bhp_ref_pa with a reason and leaves the active
setpoints unchanged; accepts anything else and makes it active. Prints ``READY`` once
the service exists and ``SERVED <n>`` when it stops: on end of stdin (the test closes
it) or after ``RIG_TEST_TIMEOUT_S`` (default 20 s), then ``EXIT 0`` before its ROS
teardown, which runs under :func:`teardown.arm_watchdog`.
"""
from __future__ import annotations

import math
import os
import select
import sys
import time

TIMEOUT_S = float(os.environ.get("RIG_TEST_TIMEOUT_S", "20"))


def check(setpoints) -> str:
    """Why ``setpoints`` are refused, or "" when they are acceptable."""
    bhp = setpoints.bhp_ref_pa
    if not math.isfinite(bhp):
        return f"bhp_ref_pa {bhp} is not a finite number"
    if bhp < 0.0:
        return f"bhp_ref_pa {bhp:g} Pa is negative: the BHP target must be >= 0 Pa (gauge)"
    return ""


def main(argv: list[str]) -> int:
    name = argv[1]
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from drill_msgs.msg import Setpoints
    from drill_msgs.srv import SetSetpoints
    from drill_ros.runner import shut_down
    from teardown import arm_watchdog

    rclpy.init(args=[])
    node = rclpy.create_node("test_dds_setpoint_server")
    state = {"active": Setpoints(), "served": 0}

    def handle(request, response):
        state["served"] += 1
        reason = check(request.setpoints)
        if not reason:
            state["active"] = request.setpoints
            state["active"].header.stamp = node.get_clock().now().to_msg()
        response.accepted = not reason
        response.reason = reason
        response.active = state["active"]
        return response

    node.create_service(SetSetpoints, name, handle)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    print("READY", flush=True)
    deadline = time.monotonic() + TIMEOUT_S
    try:
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
            if select.select([sys.stdin], [], [], 0)[0] and not sys.stdin.readline():
                break   # stdin closed: the test is done
        print(f"SERVED {state['served']}", flush=True)
        print("EXIT 0", flush=True)
        return 0
    finally:
        arm_watchdog()
        shut_down(executor, node)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
