"""Helper process for test_stop_signal: a rig node (drill_ros.runner) publishing
drill_msgs/RigMeasurement to itself, whose process receives SIGINT while rclpy converts
the first message it takes to Python, as the launcher's stop can arrive at any point:
once armed, the message class's constructor, which rclpy's C++ take calls to build the
Python message, prints ``SIGINT`` and sends the signal to this process.

    python stop_while_converting.py
"""
from __future__ import annotations

import os
import signal
import sys

from drill_msgs.msg import RigMeasurement

from drill_ros import topics
from drill_ros.node import RigNode
from drill_ros.runner import run

TOPIC = "/stop_test/measurement"
PERIOD_S = 0.05
ARMED = {"armed": False}
_construct = RigMeasurement.__init__


def construct_then_stop(self, **kwargs) -> None:
    _construct(self, **kwargs)
    if ARMED["armed"]:
        ARMED["armed"] = False
        print("SIGINT", flush=True)
        os.kill(os.getpid(), signal.SIGINT)


RigMeasurement.__init__ = construct_then_stop


class Taker(RigNode):
    def __init__(self):
        super().__init__("stop_while_converting")
        sample = RigMeasurement()           # the one message published, built before arming
        self.pub = self.create_publisher(RigMeasurement, TOPIC, topics.RELIABLE)
        self.create_subscription(RigMeasurement, TOPIC, lambda _: None, topics.RELIABLE)
        self.create_timer(PERIOD_S, lambda: self.pub.publish(sample))
        ARMED["armed"] = True               # from now on, only rclpy's take builds one


if __name__ == "__main__":
    sys.exit(run(Taker))
