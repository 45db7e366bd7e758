"""A rig process stopped while rclpy converts a message it takes exits cleanly
(drill_ros.stopping).

The launcher stops every node with SIGINT. Under rclpy's own signal handling Python's
KeyboardInterrupt was thrown into whatever bytecode ran next; when that was the
constructor of a message that rclpy's C++ take was converting, the take failed with
pybind11's "Unable to convert call argument '0' to Python object" and the process exited
with code 1 (a console or gateway node, now and then, at the end of a DDS test). The
helper (test/processes/stop_while_converting.py) sends itself SIGINT from inside that
constructor, under each executor, on a ROS domain of its own: exit code 0, no fatal line.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from drill_ros.executors import EXECUTOR_ENV, EXECUTORS
from rig_testing import held_test_domain

pytestmark = pytest.mark.dds

HELPER = Path(__file__).resolve().parent / "processes" / "stop_while_converting.py"
DOMAIN_ID = held_test_domain()
TIMEOUT_S = 60.0          # start-up on a busy machine, the first message, the exit


@pytest.mark.parametrize("executor", sorted(EXECUTORS))
def test_a_stop_while_a_taken_message_is_converted_exits_cleanly(executor):
    env = dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN_ID), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               RMW_IMPLEMENTATION="rmw_fastrtps_cpp", PYTHONUNBUFFERED="1",
               **{EXECUTOR_ENV: executor})
    done = subprocess.run([sys.executable, str(HELPER)], env=env, text=True, timeout=TIMEOUT_S,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    lines = done.stdout.splitlines()
    assert "SIGINT" in lines, done.stdout                # the stop came during the conversion
    assert done.returncode == 0, done.stdout
    assert not [line for line in lines if "[fatal]" in line or "Exception in" in line], done.stdout
