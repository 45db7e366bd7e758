"""Actuator node (one process per actuator): drawworks, choke, bpp or mud_pump.

On each measurement stamped t_k it publishes its output over the coming frame,
stamped t_k. In fast mode, when a supervisor command is due at t_k (t_k a multiple
of ``command_period_s``) it waits for the command stamped t_k first, so commands act
from the sample they were computed at. The choke honours the command's manual mode
(``choke_manual``: drive to ``choke_opening_ref``), its pressure controller
(``choke_pressure_control``: hold the measured choke dp at ``choke_dp_ref_pa``, ramped at
``choke_dp_ref_rate_pa_s``, with ``choke_flow_ref_m3s`` as flow feedforward) and otherwise
its PI flow controller on ``choke_flow_ref_m3s`` against the measured return flow (the
valve law when that sample is bad: counted as ``valve_law_frames`` on its status). Under
the command's emergency stop the drawworks sets its brake (the block decelerates to rest
and is held) and the choke holds the BHP at ``emergency_bhp_pa`` on its BHP loop. If
commands stop for longer than the watchdog timeout it holds a safe state (block held where
it is, choke opening and pumps held) and says so on its status topic. A scenario's actuator faults
(drill_core.events) act here: ``stuck`` freezes the output, ``trip`` stops a pump whatever
it is commanded; the frame names the fault acting.
"""
from __future__ import annotations

import sys

import numpy as np
from drill_msgs.msg import ActuatorFrame, RigCommand, RigMeasurement

from drill_core.events import of_owner
from drill_core.ros import topics
from drill_core.ros.context import load_context
from drill_core.ros.inbox import StampedInbox
from drill_core.ros.node import RigNode
from drill_core.ros.runner import run
from drill_core.ros.stamps import ScenarioClock, seconds_to_ns, to_ns
from drill_core.ros.status import StatusReporter
from drill_plant.actuators import Choke, Drawworks, FrameOutput, Pump, Watchdog

UNITS = {"drawworks": "m", "choke": "1", "bpp": "m^3/s", "mud_pump": "Pa"}


class ActuatorNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("actuator", **node_options)
        ctx = load_context(self, truth_side=True)
        self.ctx = ctx
        self.exit_code = 0
        self.actuator = self.declare_parameter("actuator", "drawworks").value
        if self.actuator not in UNITS:
            raise ValueError(f"parameter actuator: {self.actuator!r} is not one of {', '.join(UNITS)}")
        period = self.declare_parameter("command_period_s", ctx.config.nmpc.sample_time_s).value
        self.command_period_ns = seconds_to_ns(period)
        cfg = ctx.config
        initial = ctx.operating_point
        u_b, opening, bpp, spp = (float(v) for v in initial.inputs)
        self.model = {
            "drawworks": lambda: Drawworks(cfg.actuators, ctx.well_model.geometry.static_stretch_m, u_b),
            "choke": lambda: Choke(cfg.actuators, ctx.well_model, opening),
            "bpp": lambda: Pump(cfg.actuators.bpp, bpp),
            "mud_pump": lambda: Pump(cfg.actuators.mud_pump, spp),
        }[self.actuator]()
        self.held_command = {"drawworks": 0.0, "choke": initial.choke_flow_m3s, "bpp": bpp,
                             "mud_pump": spp}[self.actuator]
        self.step_s = cfg.plant.step_s
        self.steps = cfg.plant.steps_per_frame
        self.watchdog = Watchdog(cfg.actuators.watchdog_timeout_s)
        self.safe_hold = None
        self.command = None
        self.faults = of_owner(ctx.scenario.events, "actuator", self.actuator)
        self.clock = ScenarioClock()             # the faults' times
        self.inbox = StampedInbox(("measurement", "command"))
        self.status = StatusReporter(self, ctx.mode)
        self.pub = self.create_publisher(ActuatorFrame, topics.actuator_frame(self.actuator),
                                         topics.RELIABLE)
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement,
                                 topics.RELIABLE)
        self.create_subscription(RigCommand, topics.MACHINE_COMMAND, self._on_command,
                                 topics.RELIABLE)

    def get_name(self) -> str:  # status topic and logs carry the actuator's name
        return getattr(self, "actuator", None) or super().get_name()

    def _on_command(self, msg: RigCommand) -> None:
        self.inbox.put("command", msg)
        if self.ctx.fast:
            self._process_pending()
        else:
            self.command = msg
            self.watchdog.feed(self.get_clock().now().nanoseconds)

    def _on_measurement(self, msg: RigMeasurement) -> None:
        self.inbox.put("measurement", msg)
        if self.ctx.fast:
            self._process_pending()
        else:
            self._act(msg, self.get_clock().now().nanoseconds)

    def _process_pending(self) -> None:
        msg = self.inbox.latest("measurement")
        if msg is None:
            return
        stamp = to_ns(msg.header.stamp)
        due = self.command_period_ns > 0 and stamp % self.command_period_ns == 0
        if due and not self.inbox.has("command", stamp):
            return
        self.inbox.take("measurement", stamp)
        if due:
            self.command = self.inbox.take("command", stamp)
            self.watchdog.feed(stamp)
        self._act(msg, stamp)

    def _act(self, measurement: RigMeasurement, now_ns: int) -> None:
        tripped = self.watchdog.tripped(now_ns)
        if tripped and self.safe_hold is None:
            self.safe_hold = self._safe_command(measurement)
            if self.command is not None:
                self.status.error("command stream silent: holding the safe state")
        elif not tripped:
            self.safe_hold = None
        target = self.safe_hold if tripped else self._command_value(self.command)
        fault = self._fault(to_ns(measurement.header.stamp))
        if fault == "stuck":
            out = FrameOutput(target, target, self.model.lag.hold(self.steps))
        else:
            out = self._frame(0.0 if fault == "trip" else target, measurement, hold=tripped)
        frame = ActuatorFrame(actuator=self.actuator, unit=UNITS[self.actuator],
                              command=float(out.command),
                              output=np.asarray(out.output, dtype=float).tolist(),
                              sample_period_s=self.step_s, reference=float(out.reference),
                              watchdog_active=tripped, fault=fault)
        frame.header.stamp = measurement.header.stamp
        self.pub.publish(frame)
        self.status.mode = f"{self.ctx.mode}/{'watchdog' if tripped else 'commanded'}"
        self.status.values = {"command": out.command, "output": float(out.output[-1])}
        if self.actuator == "choke":     # frames its flow loop ran on the valve law
            self.status.values["valve_law_frames"] = float(self.model.valve_law_frames)
        self.status.tick(now_ns)

    def _fault(self, stamp_ns: int) -> str:
        """The scenario fault acting at this measurement ('' none)."""
        self.clock.start(stamp_ns)
        time_s = self.clock.seconds(stamp_ns)
        return next((e.kind for e in self.faults if e.active(time_s)), "")

    def _command_value(self, cmd: RigCommand) -> float:
        return {"drawworks": cmd.block_position_ref_m, "choke": cmd.choke_flow_ref_m3s,
                "bpp": cmd.bpp_flow_m3s,
                "mud_pump": cmd.spp_pa if cmd.mud_pump_on else 0.0}[self.actuator]

    def _safe_command(self, measurement: RigMeasurement) -> float:
        if self.actuator == "drawworks":
            return self.model.safe_reference(measurement.block_position_m)
        if self.command is None:
            return self.held_command
        return self._command_value(self.command)

    def _frame(self, target: float, m: RigMeasurement, hold: bool) -> FrameOutput:
        stop = self.command is not None and self.command.emergency_stop   # even if then silent
        if self.actuator == "drawworks":
            if stop:
                return self.model.brake(self.step_s, self.steps)
            return self.model.frame(target, m.block_position_m, self.step_s, self.steps)
        if self.actuator == "choke":
            if stop:
                cmd = self.command
                return self.model.bhp_frame(cmd.emergency_bhp_pa, m.bhp_pa, cmd.choke_dp_ref_pa,
                                            target, m.choke_dp_pa, self.step_s, self.steps)
            if hold:
                opening = self.model.lag.value
                return FrameOutput(opening, target, self.model.lag.advance(opening, self.step_s,
                                                                           self.steps))
            cmd = self.command
            if cmd.choke_pressure_control and not cmd.choke_manual:
                since_s = (to_ns(m.header.stamp) - to_ns(cmd.header.stamp)) * 1e-9
                return self.model.pressure_frame(cmd.choke_dp_ref_pa, cmd.choke_dp_ref_rate_pa_s,
                                                 since_s, target, m.choke_dp_pa, self.step_s,
                                                 self.steps)
            manual = cmd.choke_opening_ref if cmd.choke_manual else None
            return self.model.frame(target, m.choke_dp_pa, self.step_s, self.steps, manual,
                                    m.return_flow_m3s)
        return self.model.frame(target, self.step_s, self.steps)


def main(args=None) -> None:
    sys.exit(run(ActuatorNode, args))


if __name__ == "__main__":
    main()
