"""Rig floor node (a scenario with a ``trip:`` programme): the slips, the elevator, the
connections and the mud pump's ramps of a multi-stand trip; the per-frame rules are its
tick (drill_plant.floor_tick), the node moves messages.

On the measurement stamped t_k (in fast mode once the drawworks' frame stamped t_{k-1}
has come: the block's encoder) it publishes /rig/floor stamped t_k: what the floor does
over the frame [t_k, t_k + dt). The plant, the drawworks and the mud pump act on it over
that frame, the estimator and the advisor read it (docs/architecture.md).
"""
from __future__ import annotations

import sys

from drill_msgs.msg import ActuatorFrame, RigFloor, RigMeasurement

from drill_core.input_layout import U_BLOCK
from drill_ros import topics
from drill_ros.context import load_context
from drill_ros.floor import floor_message
from drill_ros.inbox import StampedInbox
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.stamps import seconds_to_ns, to_ns
from drill_ros.status import StatusReporter
from drill_plant.floor_tick import FloorTick


class FloorNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("rig_floor", **node_options)
        ctx = load_context(self)
        self.ctx = ctx
        self.exit_code = 0
        if ctx.scenario.trip is None:
            raise ValueError(f"scenario {ctx.scenario.name}: no trip programme (trip:) for "
                             "the rig floor")
        self.tick = FloorTick(ctx.config.well, ctx.scenario.trip,
                              float(ctx.operating_point.inputs[U_BLOCK]), ctx.config.plant.step_s,
                              ctx.scenario.trip.stands_pulled_at_start)
        self.frame_ns = seconds_to_ns(ctx.config.plant.sensor_period_s)
        self.inbox = StampedInbox(("measurement", "drawworks"))
        self.status = StatusReporter(self, ctx.mode)
        self.pub = self.create_publisher(RigFloor, topics.FLOOR, topics.RELIABLE)
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement,
                                 topics.RELIABLE)
        self.create_subscription(ActuatorFrame, topics.actuator_frame("drawworks"),
                                 self._on_frame, topics.RELIABLE)

    def _on_frame(self, msg: ActuatorFrame) -> None:
        if self.ctx.fast:
            self.inbox.put("drawworks", msg)
            self._process_pending()
        else:
            self.tick.drawworks_frame(msg.output)

    def _on_measurement(self, msg: RigMeasurement) -> None:
        if self.ctx.fast:
            self.inbox.put("measurement", msg)
            self._process_pending()
        else:
            self._act(msg)

    def _process_pending(self) -> None:
        msg = self.inbox.latest("measurement")
        if msg is None:
            return
        stamp = to_ns(msg.header.stamp)
        previous = stamp - self.frame_ns
        if stamp > 0 and not self.inbox.has("drawworks", previous):
            return
        self.inbox.take("measurement", stamp)
        if stamp > 0:
            self.tick.drawworks_frame(self.inbox.take("drawworks", previous).output)
        self._act(msg)

    def _act(self, m: RigMeasurement) -> None:
        stamp = to_ns(m.header.stamp)
        command = self.tick.step(stamp * 1e-9, float(m.hook_load_n), float(m.block_position_m))
        self.pub.publish(floor_message(command, self.ctx.scenario.trip, m.header.stamp))
        s = command.step
        self.status.mode = f"{self.ctx.mode}/{s.phase}"
        self.status.values = {"stand": float(s.stand), "stands_pulled": float(s.stands_pulled),
                              "pump_factor": s.pump_factor, "block_target_m": command.block_target_m}
        self.status.tick(stamp)


def main(args=None) -> None:
    sys.exit(run(FloorNode, args))


if __name__ == "__main__":
    main()
