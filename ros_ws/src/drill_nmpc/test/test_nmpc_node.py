"""NMPC node over DDS: lockstep commands on sample stamps, status, validating setpoint service.

The node runs as a child process in fast mode; this test plays the estimator (an rclpy node
with its own context on an isolated ROS_DOMAIN_ID, localhost discovery) that publishes
/clock and StateEstimate messages, records RigCommand / NmpcStatus / OperatorEvent, and
calls /set_setpoints; and the protection, answering each command on /rig/command (an echo,
or a narrowed window with a well-control target that the node must take).
"""
from __future__ import annotations

import copy
import math
import os
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
SAMPLE_NS = 1_000_000_000
TIMEOUT_S = 60.0


def _env() -> dict:
    env = dict(os.environ)
    env.update(ROS_DOMAIN_ID=str(DOMAIN_ID), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               RMW_IMPLEMENTATION="rmw_fastrtps_cpp", PYTHONUNBUFFERED="1")
    env.pop("ROS_STATIC_PEERS", None)
    return env


@pytest.fixture
def nmpc_process():
    proc = subprocess.Popen(
        [sys.executable, "-m", "drill_nmpc.nmpc_node", "--ros-args",
         "-p", f"config_dir:={CONFIG_DIR}", "-p", f"scenario:={SCENARIO}", "-p", "mode:=fast",
         "-p", "use_sim_time:=true"],
        env=_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    yield proc
    stop_process(proc)


class Estimator:
    """The estimator as far as the supervisor can tell."""

    def __init__(self, monkeypatch):
        import rclpy
        from drill_msgs.msg import (ActuatorFrame, NmpcStatus, OperatorEvent, RigCommand, Setpoints,
                                    StateEstimate)
        from drill_msgs.srv import SetSetpoints
        from rclpy.executors import SingleThreadedExecutor
        from rosgraph_msgs.msg import Clock

        from drill_ros import topics

        monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
        self.rclpy, self.topics = rclpy, topics
        self.StateEstimate, self.Clock, self.Setpoints = StateEstimate, Clock, Setpoints
        self.SetSetpoints = SetSetpoints
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=DOMAIN_ID)
        self.node = rclpy.create_node("nmpc_test_estimator", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.commands, self.statuses, self.events, self.setpoints = [], [], [], []
        self.pub_estimate = self.node.create_publisher(StateEstimate, topics.ESTIMATE, topics.RELIABLE)
        self.pub_clock = self.node.create_publisher(Clock, "/clock", topics.RELIABLE)
        self.ActuatorFrame = ActuatorFrame
        self.pub_frames = {name: self.node.create_publisher(ActuatorFrame, topics.actuator_frame(name),
                                                            topics.RELIABLE)
                           for name in ("drawworks", "bpp", "mud_pump")}
        self.answer = None         # (BHP reference, window low, high) [Pa]; None: echo
        self.pub_machine = self.node.create_publisher(RigCommand, topics.MACHINE_COMMAND,
                                                      topics.RELIABLE)
        self.sub_cmd = self.node.create_subscription(RigCommand, topics.COMMAND, self._protect,
                                                     topics.RELIABLE)
        self.node.create_subscription(NmpcStatus, topics.NMPC_STATUS, self.statuses.append,
                                      topics.RELIABLE)
        self.node.create_subscription(OperatorEvent, topics.OPERATOR_EVENTS, self.events.append,
                                      topics.RELIABLE)
        self.client = self.node.create_client(SetSetpoints, topics.SET_SETPOINTS)

    def _protect(self, cmd):
        """Record the advisor's command and answer it as the protection would."""
        self.commands.append(cmd)
        out = copy.copy(cmd)
        out.source = f"protection<{cmd.source}>"
        if self.answer is not None:
            out.bhp_ref_pa, out.bhp_window_low_pa, out.bhp_window_high_pa = self.answer
        self.pub_machine.publish(out)

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.context)

    def spin_until(self, predicate, timeout_s: float, proc) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if predicate():
                return True
            if proc.poll() is not None:
                pytest.fail(f"nmpc exited ({proc.returncode}): {proc.stdout.read()[-3000:]}")
            self.executor.spin_once(timeout_sec=0.05)
        return predicate()

    def estimate(self, stamp_ns: int, names, x) -> None:
        from drill_ros.stamps import from_ns
        stamp = from_ns(stamp_ns)
        self.pub_clock.publish(self.Clock(clock=stamp))
        msg = self.StateEstimate(state_names=list(names), mean=[float(v) for v in x])
        msg.header.stamp = stamp
        msg.bottom_influx_m3s = 0.0
        msg.string_flow_observable = True
        self.pub_estimate.publish(msg)

    def frames(self, stamp_ns: int, outputs: dict) -> None:
        """The actuators' frames over [stamp, stamp + 0.1 s): outputs held."""
        from drill_ros.stamps import from_ns
        for name, value in outputs.items():
            msg = self.ActuatorFrame(actuator=name, unit="", command=value, output=[value] * 10,
                                     sample_period_s=0.01, reference=value)
            msg.header.stamp = from_ns(stamp_ns)
            self.pub_frames[name].publish(msg)

    def latched_setpoints(self, proc, timeout_s: float = 10.0):
        """A late-joining subscriber's view of /setpoints (transient local)."""
        got = []
        sub = self.node.create_subscription(self.Setpoints, self.topics.SETPOINTS, got.append,
                                            self.topics.LATCHED)
        self.spin_until(lambda: got, timeout_s, proc)
        self.node.destroy_subscription(sub)
        return got[-1] if got else None

    def call(self, setpoints, proc):
        assert self.client.wait_for_service(timeout_sec=10.0)
        future = self.client.call_async(self.SetSetpoints.Request(setpoints=setpoints))
        assert self.spin_until(future.done, 20.0, proc), "no answer from /set_setpoints"
        return future.result()


def test_lockstep_commands_status_and_setpoint_service(nmpc_process, monkeypatch):
    from drill_core.estimation_model import build_estimation_model
    from drill_core.scenario import load_scenario_config
    from drill_nmpc.bench import steady_estimate

    scenario, config = load_scenario_config(SCENARIO, CONFIG_DIR)
    em = build_estimation_model(config, with_disturbance=False)
    x, u0 = steady_estimate(em, scenario.initial)
    nmpc = config.nmpc
    lo, hi = np.array(nmpc.input_min.as_tuple()), np.array(nmpc.input_max.as_tuple())
    est = Estimator(monkeypatch)
    try:
        assert est.spin_until(lambda: est.pub_estimate.get_subscription_count() >= 1
                              and est.pub_machine.get_subscription_count() >= 1
                              and all(p.get_subscription_count() >= 1 for p in est.pub_frames.values())
                              and est.sub_cmd.get_publisher_count() >= 1, TIMEOUT_S, nmpc_process), \
            "nmpc node did not connect"
        outputs = {"drawworks": x[0] + em.wm.geometry.static_stretch_m,   # hanging still
                   "bpp": u0[2], "mud_pump": u0[3]}
        est.estimate(0, list(em.names), x)                   # t_0: no frame before it
        est.estimate(SAMPLE_NS // 2, list(em.names), x)      # not a sample time
        est.estimate(SAMPLE_NS, list(em.names), x)           # waits for the frame at 0.9 s
        assert est.spin_until(lambda: len(est.commands) >= 1, TIMEOUT_S, nmpc_process)
        est.spin_until(lambda: False, 1.0, nmpc_process)
        assert len(est.commands) == 1, "answered t_1 before the actuator frames of t_1 - t_m"
        for s in (SAMPLE_NS, 2 * SAMPLE_NS, 3 * SAMPLE_NS):
            est.frames(s - SAMPLE_NS // 10, outputs)
            if s > SAMPLE_NS:
                est.estimate(s, list(em.names), x)
            time.sleep(0.01)
        assert est.spin_until(lambda: len(est.commands) >= 4 and len(est.statuses) >= 4, TIMEOUT_S,
                              nmpc_process), f"commands {len(est.commands)}"
        est.spin_until(lambda: False, 1.0, nmpc_process)       # nothing else may arrive
        got = [c.header.stamp.sec * 1_000_000_000 + c.header.stamp.nanosec for c in est.commands]
        assert got == [0, SAMPLE_NS, 2 * SAMPLE_NS, 3 * SAMPLE_NS]   # not the 0.5 s estimate
        for c in est.commands:
            u = np.array([c.block_position_ref_m, c.choke_flow_ref_m3s, c.bpp_flow_m3s, c.spp_pa])
            assert np.all(np.isfinite(u)) and np.all(u >= lo - 1e-9) and np.all(u <= hi + 1e-9), u
            assert c.source == "nmpc" and c.mud_pump_on
        s0 = est.statuses[0]
        assert s0.configuration == nmpc.configuration
        assert len(s0.predicted_bhp_pa) == nmpc.prediction_steps + 1
        assert len(s0.planned_spp_pa) == nmpc.prediction_steps
        assert list(s0.slack_names) and len(s0.slack_max) == len(s0.slack_names)
        assert all(math.isfinite(st.solve_time_s) and st.fallback in ("none", "relaxed", "hold")
                   for st in est.statuses)
        # near the reference: the plan holds BHP within its band
        estimated = x[em.pressure(em.n)]
        bhp = scenario.schedule[0].bhp_ref_pa
        bhp = estimated if math.isnan(bhp) else bhp        # NaN: the first estimate's BHP
        assert min(bhp, estimated) - 1.0 <= s0.bhp_ref_pa <= max(bhp, estimated) + 1.0
        assert max(abs(p - bhp) for p in s0.predicted_bhp_pa) < nmpc.bhp_band_pa

        first = est.latched_setpoints(nmpc_process)
        assert first is not None and abs(first.bhp_ref_pa - bhp) < 1.0

        bad = est.Setpoints(bhp_ref_pa=-1.0e5, bhp_band_pa=2.0e5, choke_dp_ref_pa=2.0e6,
                            choke_dp_band_pa=5.0e5, block_position_target_m=0.0,
                            trip_speed_limit_mps=0.5, controller_enabled=True, mud_pump_on=True,
                            source="test")
        answer = est.call(bad, nmpc_process)
        assert not answer.accepted and "bhp_ref_pa" in answer.reason
        assert abs(answer.active.bhp_ref_pa - bhp) < 1.0
        speedy = est.Setpoints(bhp_ref_pa=math.nan, bhp_band_pa=math.nan, choke_dp_ref_pa=math.nan,
                               choke_dp_band_pa=math.nan, block_position_target_m=math.nan,
                               trip_speed_limit_mps=2.0, controller_enabled=True,
                               mud_pump_on=True, source="test")
        answer = est.call(speedy, nmpc_process)
        assert not answer.accepted and "trip_speed_limit_mps" in answer.reason

        good = est.Setpoints(bhp_ref_pa=bhp + 1.0, bhp_band_pa=3.0e5, choke_dp_ref_pa=2.0e6,
                             choke_dp_band_pa=5.0e5, block_position_target_m=10.0,
                             trip_speed_limit_mps=0.3, controller_enabled=True, mud_pump_on=True,
                             source="test")
        answer = est.call(good, nmpc_process)
        assert answer.accepted and answer.reason == ""
        assert abs(answer.active.bhp_ref_pa - (bhp + 1.0)) < 1e-6
        latched = est.latched_setpoints(nmpc_process)
        assert latched is not None and abs(latched.bhp_ref_pa - (bhp + 1.0)) < 1e-6
        assert latched.bhp_band_pa == 3.0e5 and latched.source == "test"
        assert latched.block_position_target_m == 10.0 and latched.trip_speed_limit_mps == 0.3
        assert est.spin_until(lambda: sum(not e.accepted for e in est.events) >= 2
                              and any(e.accepted and "test" in e.text for e in est.events),
                              10.0, nmpc_process), [e.text for e in est.events]

        # the next sample uses the new setpoints: the plan moves the block toward 10 m
        est.frames(4 * SAMPLE_NS - SAMPLE_NS // 10, outputs)
        est.estimate(4 * SAMPLE_NS, list(em.names), x)
        assert est.spin_until(lambda: len(est.statuses) >= 5, TIMEOUT_S, nmpc_process)
        assert est.statuses[-1].block_position_ref_m == 10.0
        assert est.statuses[-1].predicted_block_position_m[-1] > 0.1     # heading for 10 m
        assert est.commands[-1].bhp_ref_pa == bhp + 1.0
        assert (est.commands[-1].bhp_window_low_pa, est.commands[-1].bhp_window_high_pa) \
            == config.pressure_window_pa

        # a kick answered: the protection narrows the window past our reference and holds
        # the well at its target; the next sample takes the target, fitted band and all
        target, low, high = bhp + 4.0e5, bhp + 2.75e5, config.pressure_window_pa[1]
        est.answer = (target, low, high)
        est.frames(5 * SAMPLE_NS - SAMPLE_NS // 10, outputs)
        est.estimate(5 * SAMPLE_NS, list(em.names), x)
        assert est.spin_until(lambda: len(est.commands) >= 6, TIMEOUT_S, nmpc_process)
        est.answer = None
        est.frames(6 * SAMPLE_NS - SAMPLE_NS // 10, outputs)
        est.estimate(6 * SAMPLE_NS, list(em.names), x)
        assert est.spin_until(lambda: len(est.commands) >= 7, TIMEOUT_S, nmpc_process)
        last = est.commands[-1]
        assert last.bhp_ref_pa == target
        assert (last.bhp_window_low_pa, last.bhp_window_high_pa) == (low, high)
        assert est.spin_until(lambda: any("protection: well control" in e.text and e.accepted
                                          for e in est.events), 10.0, nmpc_process)
        latched = est.latched_setpoints(nmpc_process)
        assert latched.bhp_ref_pa == target and latched.bhp_band_pa == pytest.approx(target - low)
        assert latched.source == "protection"
    finally:
        est.close()
