"""Plant node: integrates the truth plant and publishes sensors, truth, /clock and status;
the per-frame rules are its tick (drill_plant.plant_tick), the node moves messages.

fast mode (lockstep on simulated time): publish /clock, measurement and truth stamped
t_k, then wait for the four actuator frames stamped t_k (and on a multi-stand trip the
rig floor's command stamped t_k), integrate the frame and go on with t_{k+1}. Before t_0 it waits until the graph named in ``wait_for`` is
connected, so no message is published into the void. realtime mode: a wall timer at
the sensor rate integrates each frame with the latest actuator frames.
The node exits (code 0) once every node has acted on the last sample of the scenario
(the actuator frames stamped t_end have arrived; a multi-stand trip's run may end before
its duration, drill_core.tripping.run_end). It is the world of the scenario's events
(drill_core.events): formation and choke-plugging events change the plant's parameters,
sensor faults the published samples, and it announces every event on /rig/events when it
starts and when it ends.
"""
from __future__ import annotations

import sys
import time

import numpy as np
from drill_msgs.msg import ActuatorFrame, OperatorEvent, PlantTruth, RigFloor, RigMeasurement
from rosgraph_msgs.msg import Clock

from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE
from drill_core.tripping.run_end import RunEnd
from drill_ros import progress, topics
from drill_ros.context import load_context
from drill_ros.events import event_message
from drill_ros.floor import floor_command
from drill_ros.inbox import StampedInbox
from drill_ros.lockstep import LockstepStart, flush
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.stamps import from_ns, seconds_to_ns
from drill_ros.status import StatusReporter
from drill_plant.frame_lateness import FrameLateness
from drill_plant.plant_model import PARAMETER_NAMES, PlantLayout
from drill_plant.plant_tick import PlantTick
from drill_plant.simulator import PlantDiverged


class PlantNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("plant", **node_options)
        ctx = load_context(self, truth_side=True)
        self.ctx = ctx
        self.exit_code = 0
        seed = self.declare_parameter("seed", ctx.scenario.seed).value
        self.wait_for = self.declare_parameter("wait_for", [""]).value
        self.stall_timeout_s = self.declare_parameter("stall_timeout_s", 60.0).value
        self.tick = PlantTick(ctx.config, ctx.operating_point, ctx.scenario, seed)
        self.sim = self.tick.sim
        self.layout = PlantLayout(ctx.well_model.n)
        n = ctx.well_model.n      # the truth message's rows of the state
        self._pressure_rows = [self.layout.pressure(i) for i in range(1, n + 1)]
        self._flow_rows = [self.layout.flow(i) for i in range(2, n + 1)]
        self.frame_ns = seconds_to_ns(ctx.config.plant.sensor_period_s)
        self.end = RunEnd(ctx.scenario.duration_s, ctx.config.plant.sensor_period_s,
                          ctx.scenario.trip)
        self.progress = progress.PlantProgress(ctx.config.plant.sensor_period_s, ctx.scenario.duration_s)
        self.k = 0
        self.inputs = (*topics.ACTUATORS, "floor") if self.tick.multi_stand else topics.ACTUATORS
        self.frames = StampedInbox(self.inputs)
        self.status = StatusReporter(self, ctx.mode)

        self.pub_measurement = self.create_publisher(RigMeasurement, topics.MEASUREMENT, topics.RELIABLE)
        self.pub_truth = self.create_publisher(PlantTruth, topics.TRUTH, topics.RELIABLE)
        self.pub_clock = self.create_publisher(Clock, "/clock", topics.RELIABLE) if ctx.fast else None
        self.pub_events = self.create_publisher(OperatorEvent, topics.RIG_EVENTS, topics.EVENT_LOG)
        for name in topics.ACTUATORS:
            self.create_subscription(ActuatorFrame, topics.actuator_frame(name),
                                     lambda msg, n=name: self._on_frame(n, msg), topics.RELIABLE)
        if self.tick.multi_stand:
            self.create_subscription(RigFloor, topics.FLOOR,
                                     lambda msg: self._on_frame("floor", msg), topics.RELIABLE)
        if ctx.fast:
            self.lockstep = LockstepStart(self, self.wait_for, self._publish_sample,
                                          lambda: self.k, self.stall_timeout_s, self._stalled)
        else:
            self.lateness = FrameLateness(ctx.config.plant.sensor_period_s)
            self.create_timer(ctx.config.plant.sensor_period_s, self._realtime_tick)
            self._publish_sample()

    # ------------------------------------------------------------------ fast mode
    def _stalled(self) -> None:
        """Fail loudly: the lockstep stopped advancing (a lost or missing input)."""
        stamp = self.k * self.frame_ns
        missing = [n for n in self.inputs if not self.frames.has(n, stamp)]
        self.status.error(f"lockstep stalled at t = {stamp * 1e-9:.1f} s for "
                          f"{self.stall_timeout_s:.0f} s; no frame from {', '.join(missing)}",
                          fatal=True)
        self.get_logger().error(self.status.last_error)
        self.exit_code = 3
        self.finish()

    def _on_frame(self, name: str, msg: ActuatorFrame) -> None:
        self.frames.put(name, msg)
        if self.ctx.fast:
            self._try_advance()

    def _try_advance(self) -> None:
        stamp = self.k * self.frame_ns
        if not self.frames.ready(stamp):
            return
        frames = {name: self.frames.take(name, stamp) for name in self.inputs}
        if "floor" in frames:
            self.end.floor_frame(self.k, frames["floor"].phase)
            self.progress.duration_s = self.end.end_s
        if self.k < self.end.last_k:
            self._advance(frames)
            return
        self._finish(stamp)     # the frames of the last sample: every node has acted on it

    def _finish(self, stamp_ns: int) -> None:
        self.status.publish(stamp_ns)
        acked = flush((self.pub_measurement, self.pub_truth, self.pub_events))
        self.get_logger().info(f"scenario finished after {self.k} frames"
                               + ("" if acked else "; a reader had not acknowledged the last"))
        self.finish()

    # -------------------------------------------------------------- realtime mode
    def _realtime_tick(self) -> None:
        self.lateness.tick(time.monotonic())
        frames = {name: self.frames.latest(name) for name in topics.ACTUATORS}
        if any(f is None for f in frames.values()):
            held = {name: np.full(self.sim.steps_per_frame, self.sim.inputs[i])
                    for i, name in enumerate(topics.ACTUATORS)}
            frames = {name: f if f is not None else held[name] for name, f in frames.items()}
        self._advance(frames)

    # --------------------------------------------------------------------- shared
    def _advance(self, frames) -> None:
        """One frame on the actuators' frames (in realtime a held input array stands in
        for one not yet received)."""
        floor = frames.pop("floor", None)
        if floor is not None:
            self.tick.floor(floor_command(floor))
        outputs = {name: (f.output, f.command) if isinstance(f, ActuatorFrame) else (f, f[-1])
                   for name, f in frames.items()}
        try:
            for error in self.tick.advance(outputs):
                self.status.error(error)
        except PlantDiverged as err:
            self.status.error(str(err), fatal=True)
            self.status.publish(self.k * self.frame_ns)
            self.exit_code = 2
            self.finish()
            return
        self.k += 1
        self.progress.frame_done(self.k)           # rig run's progress line
        self._publish_sample()

    def _publish_sample(self) -> None:
        stamp_ns = self.k * self.frame_ns if self.ctx.fast else self.get_clock().now().nanoseconds
        stamp = from_ns(stamp_ns)
        if self.pub_clock is not None:
            self.pub_clock.publish(Clock(clock=stamp))
        time_s = self.k * self.ctx.config.plant.sensor_period_s
        notices, m = self.tick.sample(time_s)
        for notice in notices:
            self.pub_events.publish(event_message(notice, stamp))
        msg = RigMeasurement(block_position_m=m.block_position_m, choke_dp_pa=m.choke_dp_pa,
                             bhp_pa=m.bhp_pa, string_flow_m3s=m.string_flow_m3s,
                             string_flow_valid=m.string_flow_valid,
                             return_flow_m3s=m.return_flow_m3s, pit_volume_m3=m.pit_volume_m3,
                             bpp_flow_m3s=m.bpp_flow_m3s, hook_load_n=m.hook_load_n,
                             trip_tank_volume_m3=m.trip_tank_volume_m3)
        msg.header.stamp = stamp
        self.pub_measurement.publish(msg)
        self.pub_truth.publish(self._truth_msg(stamp))
        self.status.values = {"sim_time_s": stamp_ns * 1e-9, "frame": float(self.k),
                              **({} if self.ctx.fast else self.lateness.values())}
        self.status.tick(stamp_ns)
        if self.ctx.fast:
            self._try_advance()
        elif self.k >= self.end.last_k:
            self._finish(stamp_ns)

    def _truth_msg(self, stamp) -> PlantTruth:
        t = self.sim.truth()
        lay, n, x = self.layout, self.sim.wm.n, t.state
        msg = PlantTruth()
        msg.header.stamp = stamp
        msg.block_position_m = float(t.inputs[U_BLOCK])
        msg.string_position_m = float(x[lay.position])
        msg.string_velocity_mps = float(x[lay.velocity])
        msg.annulus_pressure_pa = x[self._pressure_rows].tolist()
        msg.annulus_flow_m3s = [t.choke_flow_m3s] + x[self._flow_rows].tolist()
        msg.string_flow_m3s = float(x[lay.string_flow])
        msg.string_bottom_pressure_pa = float(x[lay.string_pressure])
        msg.bit_flow_m3s = t.bit_flow_m3s
        msg.bhp_pa = float(x[lay.pressure(n)])
        msg.ecd_kgm3 = t.ecd_kgm3
        msg.annulus_friction_pa = t.annulus_friction_pa.tolist()
        msg.string_friction_pa = t.string_friction_pa
        msg.choke_opening = float(t.inputs[U_CHOKE])
        msg.bpp_flow_m3s = float(t.inputs[U_BPP_FLOW])
        msg.spp_pa = float(t.inputs[U_PUMP_PRESSURE])
        msg.influx_m3s, msg.loss_m3s = t.influx_m3s, t.loss_m3s
        msg.pit_gain_m3 = t.pit_gain_m3
        msg.influx_volume_m3, msg.loss_volume_m3 = t.influx_volume_m3, t.loss_volume_m3
        in_force = dict(zip(PARAMETER_NAMES, t.parameters))
        for name in ("pore_pressure_pa", "fracture_pressure_pa", "choke_capacity_factor"):
            setattr(msg, name, float(in_force[name]))
        return msg


def main(args=None) -> None:
    sys.exit(run(PlantNode, args))


if __name__ == "__main__":
    main()
