"""Estimator node over DDS: lockstep on stamps, finite estimates, NaN rejection.

The estimator runs as a child process in fast mode; this test is the rest of the graph:
an rclpy node (own context, isolated ROS_DOMAIN_ID, localhost discovery) that publishes
/clock, stamped measurements and the four actuator frames, and records the estimates.
"""
from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from drill_core.rig_root import config_dir
from rig_testing import held_test_domain, stop_process

pytestmark = pytest.mark.dds

DOMAIN_ID = held_test_domain()
CONFIG_DIR = config_dir()
SCENARIO = CONFIG_DIR / "scenarios" / "case2.yaml"
FRAME_NS = 100_000_000
CIRCULATION = 1000.0 / 60000.0


def _start_estimator(mode: str) -> subprocess.Popen:
    env = dict(os.environ)
    env.update(ROS_DOMAIN_ID=str(DOMAIN_ID), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               RMW_IMPLEMENTATION="rmw_fastrtps_cpp", PYTHONUNBUFFERED="1")
    env.pop("ROS_STATIC_PEERS", None)
    proc = subprocess.Popen(
        [sys.executable, "-m", "drill_estimator.estimator_node", "--ros-args",
         "-p", f"config_dir:={CONFIG_DIR}", "-p", f"scenario:={SCENARIO}", "-p", f"mode:={mode}",
         "-p", f"use_sim_time:={'true' if mode == 'fast' else 'false'}"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return proc


@pytest.fixture
def estimator_process():
    proc = _start_estimator("fast")
    yield proc
    stop_process(proc)


@pytest.fixture
def realtime_estimator_process():
    proc = _start_estimator("realtime")
    yield proc
    stop_process(proc)


class Feeder:
    """The plant and actuators as far as the estimator can tell."""

    def __init__(self, monkeypatch):
        import rclpy
        from drill_msgs.msg import ActuatorFrame, RigMeasurement, StateEstimate
        from rclpy.executors import SingleThreadedExecutor
        from rosgraph_msgs.msg import Clock

        from drill_ros import topics

        monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
        self.rclpy = rclpy
        self.ActuatorFrame, self.RigMeasurement, self.Clock = ActuatorFrame, RigMeasurement, Clock
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=DOMAIN_ID)
        self.node = rclpy.create_node("estimator_test_feeder", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.estimates = []
        self.pub_measurement = self.node.create_publisher(RigMeasurement, topics.MEASUREMENT,
                                                          topics.RELIABLE)
        self.pub_clock = self.node.create_publisher(Clock, "/clock", topics.RELIABLE)
        self.pub_frames = {name: self.node.create_publisher(ActuatorFrame, topics.actuator_frame(name),
                                                            topics.RELIABLE)
                           for name in topics.ACTUATORS}
        self.sub = self.node.create_subscription(StateEstimate, topics.ESTIMATE,
                                                 self.estimates.append, topics.RELIABLE)

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.context)

    def spin_until(self, predicate, timeout_s: float, proc=None) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if predicate():
                return True
            if proc is not None and proc.poll() is not None:
                pytest.fail(f"estimator exited ({proc.returncode}): {proc.stdout.read()[-3000:]}")
            self.executor.spin_once(timeout_sec=0.05)
        return predicate()

    def connected(self) -> bool:
        return (self.pub_measurement.get_subscription_count() >= 1
                and all(p.get_subscription_count() >= 1 for p in self.pub_frames.values())
                and self.sub.get_publisher_count() >= 1)

    def measurement(self, k: int, y, circulating: bool = True) -> None:
        from drill_ros.stamps import from_ns
        stamp = from_ns(k * FRAME_NS)
        self.pub_clock.publish(self.Clock(clock=stamp))
        msg = self.RigMeasurement()
        msg.header.stamp = stamp
        msg.block_position_m, msg.choke_dp_pa, msg.bhp_pa = (float(v) for v in y[:3])
        msg.string_flow_m3s = float(y[3]) if circulating else math.nan
        msg.string_flow_valid = circulating
        self.pub_measurement.publish(msg)

    def frames(self, k: int, outputs: dict) -> None:
        from drill_ros.stamps import from_ns
        for name, (value, reference) in outputs.items():
            msg = self.ActuatorFrame()
            msg.header.stamp = from_ns(k * FRAME_NS)
            msg.actuator = name
            msg.command = float(value)
            msg.output = [float(value)] * 10
            msg.sample_period_s = 0.01
            msg.reference = float(reference)
            self.pub_frames[name].publish(msg)


def _stamps(estimates):
    return [e.header.stamp.sec * 1_000_000_000 + e.header.stamp.nanosec for e in estimates]


def _finite(estimate) -> bool:
    values = [*estimate.mean, *estimate.covariance_diagonal, *estimate.friction_parameter,
              *estimate.friction_pa, estimate.bhp_pa, estimate.choke_dp_pa, estimate.nis]
    return all(math.isfinite(v) for v in values)


def _operating_point():
    """A circulating steady state: measurement and actuator outputs (value, reference)."""
    from drill_core import hydraulics as hy
    from drill_core.config import load_rig
    from drill_plant.plant_model import PlantLayout, steady_state

    cfg = load_rig(CONFIG_DIR)
    wm = hy.rig_well_model(cfg)
    ss = steady_state(wm, CIRCULATION, 2.0e6, 0.0)
    lay = PlantLayout(wm.n)
    y = np.array([0.0, 2.0e6, ss.state[lay.pressure(wm.n)], CIRCULATION])
    outputs = {"drawworks": (ss.inputs[0], 0.0), "choke": (ss.inputs[1], ss.choke_flow_m3s),
               "bpp": (0.0, 0.0), "mud_pump": (ss.inputs[3], ss.inputs[3])}
    return y, outputs


def test_estimator_node_lockstep_and_rejection(estimator_process, monkeypatch):
    y, outputs = _operating_point()
    feeder = Feeder(monkeypatch)
    try:
        assert feeder.spin_until(feeder.connected, 30.0, estimator_process), "estimator not connected"
        feeder.spin_until(lambda: False, 0.5)         # let the reverse discovery settle

        # k = 0 initialises from the measurement alone
        feeder.measurement(0, y)
        assert feeder.spin_until(lambda: len(feeder.estimates) == 1, 20.0, estimator_process)
        first = feeder.estimates[0]
        assert _stamps(feeder.estimates) == [0]
        assert _finite(first) and first.nis_dof == 0
        assert len(first.mean) == len(first.state_names) == 16
        # the start: the model's steady state through the reading, up to the sensor's share of
        # the (here Pa-sized) departure of the plant's profile from the model's
        assert abs(first.bhp_pa - y[2]) < 1.0e3 and first.string_flow_observable

        # measurement t1 before the frames stamped t0: the estimator must wait for them
        feeder.measurement(1, y)
        feeder.spin_until(lambda: len(feeder.estimates) > 1, 1.0, estimator_process)
        assert len(feeder.estimates) == 1
        feeder.frames(0, outputs)
        assert feeder.spin_until(lambda: len(feeder.estimates) == 2, 20.0, estimator_process)
        second = feeder.estimates[1]
        assert _stamps(feeder.estimates) == [0, FRAME_NS]
        assert _finite(second) and second.nis_dof == 4 and len(second.innovation) == 4
        assert list(second.measurement_names)[-1] == "string_flow_m3s"
        assert abs(second.bhp_pa - y[2]) < 2.0e5 and second.rejected_measurements == 0

        # frames first this time, then a NaN BHP: that channel left out and counted, the
        # other three fused, the estimate still finite
        feeder.frames(1, outputs)
        bad = y.copy()
        bad[2] = math.nan
        feeder.measurement(2, bad)
        assert feeder.spin_until(lambda: len(feeder.estimates) == 3, 20.0, estimator_process)
        third = feeder.estimates[2]
        assert _stamps(feeder.estimates)[-1] == 2 * FRAME_NS
        assert third.rejected_measurements == 1 and third.nis_dof == 3
        assert "bhp_pa" not in list(third.measurement_names)
        assert _finite(third)

        # pump off: the string-flow row is dropped and reported unobservable
        feeder.frames(2, outputs)
        feeder.measurement(3, y, circulating=False)
        assert feeder.spin_until(lambda: len(feeder.estimates) == 4, 20.0, estimator_process)
        fourth = feeder.estimates[3]
        assert _stamps(feeder.estimates)[-1] == 3 * FRAME_NS
        assert not fourth.string_flow_observable and fourth.nis_dof == 3
        assert fourth.rejected_measurements == 1 and _finite(fourth)
    finally:
        feeder.close()
    estimator_process.send_signal(signal.SIGTERM)
    assert estimator_process.wait(timeout=15) == 0


def test_estimator_node_realtime_uses_latest_frames(realtime_estimator_process, monkeypatch):
    proc = realtime_estimator_process
    y, outputs = _operating_point()
    feeder = Feeder(monkeypatch)
    try:
        assert feeder.spin_until(feeder.connected, 30.0, proc), "estimator not connected"
        feeder.spin_until(lambda: False, 0.5)
        feeder.measurement(0, y)
        assert feeder.spin_until(lambda: len(feeder.estimates) == 1, 20.0, proc)
        # no waiting in realtime mode: a measurement without frames is processed at once
        # (inputs held from the initial steady state), later ones with the latest frames
        feeder.measurement(1, y)
        assert feeder.spin_until(lambda: len(feeder.estimates) == 2, 20.0, proc)
        feeder.frames(1, outputs)
        feeder.spin_until(lambda: False, 0.3)
        feeder.measurement(2, y)
        assert feeder.spin_until(lambda: len(feeder.estimates) == 3, 20.0, proc)
        assert _stamps(feeder.estimates) == [0, FRAME_NS, 2 * FRAME_NS]
        for estimate in feeder.estimates:
            assert _finite(estimate) and abs(estimate.bhp_pa - y[2]) < 2.0e5
        assert [e.nis_dof for e in feeder.estimates] == [0, 4, 4]
    finally:
        feeder.close()
