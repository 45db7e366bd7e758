"""DDS foundation: our own interfaces travel between processes over Fast DDS.

(a) a publisher process sends N drill_msgs/RigMeasurement (reliable, keep-all) and a
    subscriber process receives every one; the decoded values are checked.
(b) a SetSetpoints server process refuses a negative bhp_ref_pa with a reason and
    accepts a valid request; the client is an rclpy node in this process with its own
    context.

Everything runs on an isolated ROS_DOMAIN_ID with localhost-only discovery; names carry
a per-run suffix so concurrent runs cannot cross-talk. Every wait has a deadline, so a
hang fails the test instead of blocking. A child's result is the ``EXIT <code>`` it prints
before its ROS teardown; a teardown stuck past the child's watchdog
(``processes/teardown.py``) is reported with its stacks as a warning, not as the result.
"""
from __future__ import annotations

import importlib.util
import json
import math
import os
import queue
import subprocess
import sys
import threading
import time
import uuid
import warnings
from pathlib import Path

import pytest
from rig_testing import held_test_domain

pytestmark = pytest.mark.dds

HELPERS = Path(__file__).resolve().parent / "processes"
DOMAIN_PUBSUB = held_test_domain()
DOMAIN_SERVICE = held_test_domain()
TIMEOUT_S = 20.0           # each child gives up after this; the test waits a little longer
EXIT_TIMEOUT_S = 60.0      # a child's exit includes DDS teardown, which under load has taken
                           # over 10 s: this deadline only catches a hang


def _helper_module(name: str):
    spec = importlib.util.spec_from_file_location(f"rig_test_helper_{name}", HELPERS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


STUCK_MARK = _helper_module("teardown").STUCK_MARK   # how a helper's stuck teardown reads


def child_env(domain_id: int) -> dict[str, str]:
    env = dict(os.environ)
    env.update(ROS_DOMAIN_ID=str(domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               RMW_IMPLEMENTATION="rmw_fastrtps_cpp", RIG_TEST_TIMEOUT_S=str(TIMEOUT_S),
               PYTHONUNBUFFERED="1")
    env.pop("ROS_STATIC_PEERS", None)
    return env


class Child:
    """A helper process whose stdout lines can be awaited with a timeout."""

    def __init__(self, args: list[str], env: dict[str, str]):
        self.args = args
        self.proc = subprocess.Popen([sys.executable, *args], env=env, text=True,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE)
        self.lines: queue.Queue[str | None] = queue.Queue()
        self.seen: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.put(line.rstrip("\n"))
        self.lines.put(None)

    def expect(self, prefix: str, timeout: float = TIMEOUT_S + 5.0) -> str:
        """The next stdout line starting with ``prefix``; fails on timeout or exit."""
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                pytest.fail(f"{self.args[0]}: no {prefix!r} line within {timeout:.0f} s; "
                            f"stdout so far {self.seen}")
            try:
                line = self.lines.get(timeout=remaining)
            except queue.Empty:
                continue
            if line is None:
                self.proc.wait(timeout=5)
                pytest.fail(f"{self.args[0]} exited ({self.proc.returncode}) before {prefix!r}; "
                            f"stdout {self.seen}; stderr {self.proc.stderr.read()[-2000:]}")
            self.seen.append(line)
            if line.startswith(prefix):
                return line

    def send(self, text: str) -> None:
        self.proc.stdin.write(text)
        self.proc.stdin.flush()

    def finish(self, timeout: float = EXIT_TIMEOUT_S) -> int:
        """Close stdin, wait for the process to end (killing it on timeout) and return the
        code of its ``EXIT`` line, which must be its exit code unless its teardown stuck."""
        try:
            self.proc.stdin.close()
        except BrokenPipeError:
            pass
        announced = int(self.expect("EXIT").split()[1])
        try:
            exit_code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            pytest.fail(f"{self.args[0]} did not exit within {timeout} s")
        stderr = self.proc.stderr.read()
        if STUCK_MARK in stderr:
            warnings.warn(f"{self.args[0]}: ROS teardown stuck after EXIT {announced}; "
                          f"stacks:\n{stderr[stderr.index(STUCK_MARK):][:4000]}")
            return announced
        assert exit_code == announced, f"{self.args[0]}: EXIT {announced} but exit code {exit_code}"
        return exit_code

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=5)


@pytest.fixture
def children():
    started: list[Child] = []

    def start(script: str, *args: str, domain_id: int) -> Child:
        child = Child([str(HELPERS / script), *args], child_env(domain_id))
        started.append(child)
        return child

    yield start
    for child in started:
        child.kill()
        for stream in (child.proc.stdin, child.proc.stdout, child.proc.stderr):
            try:
                stream.close()
            except Exception:
                pass


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


# ------------------------------------------------------------------- (a) topics
def test_rig_measurements_reach_another_process(children):
    count = 200
    topic = f"/test_dds/measurement_{uuid.uuid4().hex[:8]}"
    t0 = time.monotonic()
    sub = children("dds_measurements.py", "sub", topic, str(count), domain_id=DOMAIN_PUBSUB)
    pub = children("dds_measurements.py", "pub", topic, str(count), domain_id=DOMAIN_PUBSUB)
    pub.expect("MATCHED")
    sub.expect("MATCHED")
    pub.send("go\n")
    assert pub.expect("SENT") == f"SENT {count} acked=True"
    result = json.loads(sub.expect("{"))          # json.loads accepts the NaN the child wrote
    assert pub.finish() == 0
    assert sub.finish() == 0
    print(f"\n{count} RigMeasurement samples across processes in {time.monotonic() - t0:.2f} s")

    received = result["received"]
    assert len(received) == count
    expected = [_helper_module("dds_measurements").sample_values(i) for i in range(count)]
    for i, (got, want) in enumerate(zip(received, expected)):
        assert set(got) == set(want)
        bad = {k: (got[k], want[k]) for k in want if not _same(got[k], want[k])}
        assert not bad, f"sample {i}: received != sent: {bad}"
    # the invalid flow samples arrive as NaN with the flag down
    assert sum(1 for r in received if not r["string_flow_valid"]) == count // 5
    assert all(math.isnan(r["string_flow_m3s"]) for r in received if not r["string_flow_valid"])


# ----------------------------------------------------------------- (b) service
def _call(executor, client, request, timeout: float = 10.0):
    future = client.call_async(request)
    executor.spin_until_future_complete(future, timeout_sec=timeout)
    if not future.done():
        client.remove_pending_request(future)
        pytest.fail(f"no SetSetpoints response within {timeout} s")
    return future.result()


def test_set_setpoints_service_refuses_negative_bhp(children, monkeypatch):
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from drill_msgs.msg import Setpoints
    from drill_msgs.srv import SetSetpoints

    name = f"/test_dds/set_setpoints_{uuid.uuid4().hex[:8]}"
    server = children("dds_setpoint_server.py", name, domain_id=DOMAIN_SERVICE)
    server.expect("READY")

    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    context = Context()
    rclpy.init(args=[], context=context, domain_id=DOMAIN_SERVICE)
    try:
        node = rclpy.create_node("test_set_setpoints_client", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        client = node.create_client(SetSetpoints, name)
        assert client.wait_for_service(timeout_sec=TIMEOUT_S), "SetSetpoints service not found"

        def request(bhp_ref_pa: float, source: str) -> SetSetpoints.Request:
            req = SetSetpoints.Request()
            req.setpoints = Setpoints(bhp_ref_pa=bhp_ref_pa, bhp_band_pa=2.0e5,
                                      choke_dp_ref_pa=5.0e5, choke_dp_band_pa=5.0e5,
                                      block_position_target_m=10.0, trip_speed_limit_mps=0.5,
                                      controller_enabled=True, mud_pump_on=True, source=source)
            return req

        ok = _call(executor, client, request(3.0e7, "operator"))
        assert ok.accepted is True
        assert ok.reason == ""
        assert ok.active.bhp_ref_pa == 3.0e7
        assert ok.active.source == "operator"
        assert ok.active.controller_enabled is True

        refused = _call(executor, client, request(-1.0e5, "scenario"))
        assert refused.accepted is False
        assert "bhp_ref_pa" in refused.reason and "negative" in refused.reason
        assert "-100000" in refused.reason
        # a refusal changes nothing: the accepted setpoints stay active
        assert refused.active.bhp_ref_pa == 3.0e7
        assert refused.active.source == "operator"

        ok2 = _call(executor, client, request(2.5e7, "scenario"))
        assert (ok2.accepted, ok2.reason, ok2.active.bhp_ref_pa) == (True, "", 2.5e7)

        executor.shutdown()
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
    assert server.finish() == 0
    assert "SERVED 3" in server.seen
