"""Helpers shared by the DDS tests: a node spinning in its own context, polling, stopping
a node's process, and the comparison of two runs' recorded data."""
from __future__ import annotations

import asyncio
import math
import signal
import subprocess
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor

from drill_bag import mcap_io
from drill_bringup import launcher
from drill_ros import topics

# what a fast-mode run's scenario and seed alone decide: the lockstep's data
DETERMINISTIC_TOPICS = (topics.TRUTH, topics.MEASUREMENT, topics.ESTIMATE, topics.COMMAND,
                        topics.MACHINE_COMMAND)


@contextmanager
def spinning_node(domain_id: int, name: str, monkeypatch, make=None):
    """A node on ``domain_id`` (localhost discovery), spun by a background thread: a plain
    one named ``name``, or ``make(context)``'s."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    node = make(context) if make else rclpy.create_node(name, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    try:
        yield node
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
        thread.join(timeout=5)


async def until(read, predicate, timeout_s: float, what: str = ""):
    """Await ``read()`` until ``predicate`` holds of its value; the value. Fails naming
    ``what`` and the last value after ``timeout_s``."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while not predicate(value := await read()):
        assert loop.time() < deadline, f"timed out waiting for {what}; last {value!r}"
        await asyncio.sleep(0.02)
    return value


def stop_process(proc: subprocess.Popen) -> None:
    """Stop a node's process as a launcher does: SIGTERM, 10 s to exit cleanly, then kill."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)


def wait_for(predicate, timeout_s: float, what: str) -> None:
    """Poll ``predicate`` until true; fail the test naming ``what`` after ``timeout_s``."""
    deadline_s = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline_s, f"timed out waiting for {what}"
        time.sleep(0.02)


def assert_same_recorded_data(path_a: Path, path_b: Path,
                              compared=DETERMINISTIC_TOPICS) -> int:
    """Assert that two recordings hold the same messages on the ``compared`` topics, at the
    same publish times and field by field (NaN equals NaN; the NMPC's solve time, a
    wall-clock figure, is left out); returns the number of messages compared."""
    a = list(mcap_io.decoded_messages(path_a, compared))
    b = list(mcap_io.decoded_messages(path_b, compared))
    key = lambda pair: (pair[0].topic, pair[0].publish_time_ns)
    a.sort(key=key)
    b.sort(key=key)
    assert len(a) == len(b), (len(a), len(b))
    for (ra, ma), (rb, mb) in zip(a, b):
        assert ra.topic == rb.topic and ra.publish_time_ns == rb.publish_time_ns
        fields = [f for f in ma.__slots__ if f != "header"] if hasattr(ma, "__slots__") else None
        for name in fields or [f for f in dir(ma) if not f.startswith("_") and f != "header"]:
            va, vb = getattr(ma, name), getattr(mb, name)
            if callable(va):
                continue
            if isinstance(va, float) and math.isnan(va):
                assert math.isnan(vb)
            elif name == "solve_time_s":
                continue
            else:
                assert np.array_equal(np.asarray(va), np.asarray(vb)), (ra.topic, name)
    return len(a)


def held_test_domain() -> int:
    """A ROS domain of the tests' range that no other process of this machine holds (an
    flock kept until this process exits: drill_bringup.launcher.held_domain), so test
    modules running at once in parallel workers never see each other's graphs."""
    return launcher.held_domain(launcher.TEST_DOMAINS)
