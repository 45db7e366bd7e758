"""Estimator node: the rig's UKF (drill_estimator.ukf) on topics (docs/design.md §2 and §5).

Subscribes /rig/measurement and /actuators/<name>/frame for the four actuators (never the
truth topic); publishes drill_msgs/StateEstimate on /estimator/estimate stamped with the
measurement it used, and NodeStatus on /estimator/status.

fast mode (lockstep): the plant publishes the measurement stamped t_k after integrating
the frame [t_{k-1}, t_k) that the actuator frames stamped t_{k-1} describe. On a
measurement t_k the node waits (StampedInbox) until all four frames stamped t_{k-1} are
in, runs one time update per plant step of that frame, fuses y(t_k) and publishes the
estimate stamped t_k. The first measurement initialises the filter (no frames needed).
Measurements and frames may arrive in any order across topics; every message is keyed by
its stamp, so the result does not depend on timing.

realtime mode: each measurement is processed on arrival with the latest frame of each
actuator (inputs held when a frame is missing).

Each sample is one step of drill_estimator.tick (the channels screened, the time update
over the actuator frames, the update); the estimate reports the frozen channels and the
age of the stalest channel, so a dropout shows as staleness while the filter rides on its
model (its covariance grows).

Run: python -m drill_estimator.estimator_node --ros-args -p config_dir:=<dir> -p mode:=fast
     -p use_sim_time:=true
"""
from __future__ import annotations

import math
import time

import numpy as np
from drill_msgs.msg import ActuatorFrame, RigFloor, RigMeasurement, StateEstimate
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration

from drill_ros import topics
from drill_ros.context import load_context
from drill_ros.floor import floor_command
from drill_ros.inbox import StampedInbox
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.stamps import to_ns
from drill_ros.status import StatusReporter
from drill_core.estimation_model import MEASUREMENT_NAMES
from drill_core.tripping.run_end import RunEnd
from drill_estimator.tick import EstimatorTick
from drill_estimator.ukf import UpdateResult


class EstimatorNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("estimator", **node_options)
        ctx = load_context(self)
        self.ctx = ctx
        cfg = ctx.config
        self.tick = EstimatorTick(cfg, ctx.scenario.pulled_at_start_m)
        self.ukf, self.watch, self.inputs = self.tick.ukf, self.tick.watch, self.tick.inputs
        self.frozen: tuple[str, ...] = ()
        self.steps = cfg.plant.steps_per_frame
        self.step_ns = int(round(cfg.plant.step_s * 1e9))
        self.frame_ns = int(round(cfg.plant.sensor_period_s * 1e9))
        self.end = RunEnd(ctx.scenario.duration_s, cfg.plant.sensor_period_s, ctx.scenario.trip)
        self.exit_code = 0
        self.status = StatusReporter(self, ctx.mode)

        self.multi_stand = ctx.scenario.trip is not None
        # the frames stamped t_{k-1} a sample t_k waits for, and on a multi-stand trip the
        # rig floor's command for that frame (its slips; the stands it racked)
        self.awaited = (*topics.ACTUATORS, "floor") if self.multi_stand else topics.ACTUATORS
        self.frames = StampedInbox(self.awaited)               # fast mode
        self.latest: dict[str, ActuatorFrame] = {}             # realtime mode
        self.pending: dict[int, RigMeasurement] = {}           # fast mode, by stamp
        self.previous_ns: int | None = None                    # stamp of the last measurement used
        self.frame_ms = 0.0

        self.pub = self.create_publisher(StateEstimate, topics.ESTIMATE, topics.RELIABLE)
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement,
                                 topics.RELIABLE)
        for name in topics.ACTUATORS:
            self.create_subscription(ActuatorFrame, topics.actuator_frame(name),
                                     lambda msg, n=name: self._on_frame(n, msg), topics.RELIABLE)
        if self.multi_stand:
            self.create_subscription(RigFloor, topics.FLOOR,
                                     lambda msg: self._on_frame("floor", msg), topics.RELIABLE)
        # a wall-clock heartbeat: without it a node that only reacts to messages blocks in
        # the middle-ware wait and a Python-level SIGTERM handler never gets to run
        self.create_timer(0.25, lambda: None, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(
            f"estimator ready: mode {ctx.mode}, {self.ukf.n_x} states, block input "
            f"{self.ukf.block_input}")

    # ------------------------------------------------------------------ inputs
    def _on_measurement(self, msg: RigMeasurement) -> None:
        if self.ctx.fast:
            stamp = to_ns(msg.header.stamp)
            if self.previous_ns is not None and stamp <= self.previous_ns:
                self.status.error(f"measurement stamped {stamp} ns is not newer than the last one "
                                  f"({self.previous_ns} ns); ignored")
                return
            self.pending[stamp] = msg
            self._drain()
        else:
            self._process(msg, {name: self.latest.get(name) for name in topics.ACTUATORS})

    def _on_frame(self, name: str, msg: ActuatorFrame) -> None:
        if self.ctx.fast:
            self.frames.put(name, msg)
            self._drain()
        else:
            self.latest[name] = msg

    def _drain(self) -> None:
        """Process pending measurements in stamp order while their frames are in."""
        while self.pending:
            stamp = min(self.pending)
            if self.previous_ns is not None:
                lost = [n for n in self.awaited if self.frames.passed(n, self.previous_ns)]
                if not self.frames.ready(self.previous_ns,
                                         [n for n in self.awaited if n not in lost]):
                    return
                if lost:
                    self.status.error(f"frames stamped {self.previous_ns} ns of {', '.join(lost)} "
                                      "lost (a later one came first): their inputs held")
                frames = {name: self.frames.take(name, self.previous_ns)
                          for name in self.awaited if name not in lost}
                if "floor" in frames:
                    self.end.floor_frame(self.previous_ns // self.frame_ns,
                                         frames["floor"].phase)
            else:
                frames = {}
            self._process(self.pending.pop(stamp), frames)
            if stamp == self.end.last_k * self.frame_ns:
                self._finish()
                return

    def _finish(self) -> None:
        """Fast mode: the scenario's last sample is estimated; once the recorder (and every
        reader) has acknowledged it, exit, so a run never ends with the estimator behind
        (nothing waits for it in open-loop and baseline runs)."""
        self.pub.wait_for_all_acked(Duration(seconds=5.0))
        self.get_logger().info(f"last sample estimated (t = {self.end.end_s:.1f} s); exiting")
        self.finish()

    # -------------------------------------------------------------- filtering
    def _process(self, msg: RigMeasurement, frames) -> None:
        started = time.perf_counter()
        stamp = to_ns(msg.header.stamp)
        steps = self.steps
        if self.previous_ns is not None and not self.ctx.fast:
            steps = int(np.clip(round((stamp - self.previous_ns) / self.step_ns), 1, 10 * self.steps))
        initialised = self.ukf.initialised
        floor = frames.pop("floor", None)
        held = pump_stopped = False
        if floor is not None:
            command = floor_command(floor)
            if command.racked_to_m is not None:
                self.tick.rack(command.racked_from_m, command.racked_to_m)
            held = command.string_held
            pump_stopped = command.pump_stopped
        tick = self.tick.step(stamp * 1e-9, msg, frames, steps, held, pump_stopped)
        self.frozen = tick.frozen
        for problem in tick.problems:
            self.status.error(problem)
        self.previous_ns = stamp
        if not self.ukf.initialised:
            return                         # could not initialise: nothing to publish
        if initialised:
            self.frame_ms = (time.perf_counter() - started) * 1e3
        self._publish(msg, tick.update)

    # --------------------------------------------------------------- outputs
    def _publish(self, measurement: RigMeasurement, result: UpdateResult | None) -> None:
        ukf = self.ukf
        msg = StateEstimate()
        msg.header.stamp = measurement.header.stamp
        msg.header.frame_id = measurement.header.frame_id
        msg.state_names = list(ukf.state_names)
        msg.mean = [float(v) for v in ukf.mean]
        msg.covariance_diagonal = [float(v) for v in ukf.covariance_diagonal]
        msg.friction_parameter = [float(v) for v in ukf.theta]
        msg.friction_pa = [float(v) for v in ukf.friction_pa]
        if result is not None and result.accepted:
            msg.measurement_names = list(result.measurement_names)
            msg.innovation = [float(v) for v in result.innovation]
            msg.nis = float(result.nis)
            msg.nis_dof = int(result.nis_dof)
        else:                             # initialisation or rejected sample: nothing fused
            msg.nis = 0.0
            msg.nis_dof = 0
        msg.string_flow_observable = bool(measurement.string_flow_valid)
        msg.bhp_pa = ukf.bhp_pa
        msg.choke_dp_pa = ukf.choke_dp_pa
        msg.string_velocity_mps = ukf.string_velocity_mps
        msg.bottom_influx_m3s = ukf.bottom_influx_m3s
        msg.rejected_measurements = int(ukf.rejected + ukf.rejected_channels)   # samples and channels
        msg.frozen_channels = list(self.frozen)
        stamp_s = to_ns(measurement.header.stamp) * 1e-9
        msg.oldest_channel_age_s = self.watch.oldest_age_s(
            stamp_s, None if measurement.string_flow_valid else MEASUREMENT_NAMES[:3])
        msg.covariance_inflations = int(ukf.inflations)
        self.pub.publish(msg)

        stamp_ns = to_ns(measurement.header.stamp)
        window_nis = float(result.window_nis_per_dof) if result is not None else math.nan
        self.status.values = {
            "nis": msg.nis,
            "nis_dof": float(msg.nis_dof),
            "nis_window_per_dof": 0.0 if math.isnan(window_nis) else window_nis,
            "rejected": float(ukf.rejected), "rejected_channels": float(ukf.rejected_channels),
            "frozen_samples": float(self.watch.frozen_samples),
            "valve_law_frames": float(self.inputs.valve_law_frames),
            "inflations": float(ukf.inflations),
            "repairs": float(ukf.repairs),
            "resets": float(ukf.resets),
            "string_flow_observable": float(msg.string_flow_observable),
            "frame_update_time_ms": self.frame_ms,
            "bhp_pa": msg.bhp_pa,
        }
        self.status.tick(stamp_ns)


def main(args=None) -> None:
    raise SystemExit(run(EstimatorNode, args))


if __name__ == "__main__":
    main()
