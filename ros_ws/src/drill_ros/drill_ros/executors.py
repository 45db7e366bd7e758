"""The executor a process spins its nodes with, chosen by the launcher for the whole run
($DRILL_EXECUTOR): rclpy's events executor (default: it hands a message to its callback
several times faster than the single-threaded executor, which rebuilds its wait set in
Python on every spin) or the single-threaded one. Processes spin with ``spin_once`` in a
loop of their own: the events executor's ``spin`` stays in its C++ loop and never runs the
nodes' Python timers."""
from __future__ import annotations

import os

from rclpy.executors import SingleThreadedExecutor
from rclpy.experimental import EventsExecutor

EXECUTOR_ENV = "DRILL_EXECUTOR"
SPIN_TIMEOUT_S = 0.25     # a spin returns to Python at least this often (signals, checks)
EXECUTORS = {"events": EventsExecutor, "single_threaded": SingleThreadedExecutor}
DEFAULT_EXECUTOR = "events"


def create_executor():
    """A new executor of the kind $DRILL_EXECUTOR names (the default if unset)."""
    kind = os.environ.get(EXECUTOR_ENV, DEFAULT_EXECUTOR)
    if kind not in EXECUTORS:
        raise ValueError(f"{EXECUTOR_ENV}={kind!r}: must be one of {', '.join(EXECUTORS)}")
    return EXECUTORS[kind]()
