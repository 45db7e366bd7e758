"""Drilling plant node (``drilling_plant``): the drill string of a drilling scenario
(drill_string.plant) in the fast-mode lockstep.

For frame k (t_k = k T, T = config/drilling.yaml sensor_period_s): publish /clock, the
downhole measurement, the truth (every step of the frame just integrated) and the surface
measurement stamped t_k; wait for the top drive's and the block feed's frames stamped t_k;
integrate [t_k, t_k+1) on their samples and go on with t_k+1. Before t_0 it waits until
the graph named in ``wait_for`` is connected (drill_ros.lockstep); it exits (code 0)
once the drives' frames of the last sample have arrived.
"""
from __future__ import annotations

import sys

from drill_msgs.msg import (ActuatorFrame, DownholeMeasurement, DrillingTruth,
                            SurfaceMeasurement)
from rosgraph_msgs.msg import Clock

from drill_ros import progress, topics
from drill_ros.inbox import StampedInbox
from drill_ros.lockstep import LockstepStart, flush
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.stamps import from_ns, seconds_to_ns
from drill_ros.status import StatusReporter
from drill_string.plant import DOWNHOLE_CHANNELS, SURFACE_CHANNELS, DrillingPlant
from drill_string.ros.context import load_drilling_context
from drill_string.simulate import TRAJECTORY_FIELDS


class DrillingPlantNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("drilling_plant", **node_options)
        ctx = load_drilling_context(self)
        self.exit_code = 0
        seed = self.declare_parameter("seed", ctx.scenario.seed).value
        wait_for = self.declare_parameter("wait_for", [""]).value
        self.stall_timeout_s = self.declare_parameter("stall_timeout_s", 60.0).value
        self.plant = DrillingPlant(ctx.scenario, ctx.rig, seed)
        self.frame_ns = seconds_to_ns(ctx.rig.sensor_period_s)
        self.last_k = int(round(ctx.scenario.duration_s / ctx.rig.sensor_period_s))
        self.progress = progress.PlantProgress(ctx.rig.sensor_period_s, ctx.scenario.duration_s)
        self.k = 0
        self.frames = StampedInbox(topics.DRILLING_ACTUATORS)
        self.status = StatusReporter(self, "fast")
        self.pub_clock = self.create_publisher(Clock, "/clock", topics.RELIABLE)
        self.pub_downhole = self.create_publisher(DownholeMeasurement, topics.DOWNHOLE,
                                                  topics.RELIABLE)
        self.pub_truth = self.create_publisher(DrillingTruth, topics.DRILLING_TRUTH,
                                               topics.RELIABLE)
        self.pub_surface = self.create_publisher(SurfaceMeasurement, topics.SURFACE,
                                                 topics.RELIABLE)
        for name in topics.DRILLING_ACTUATORS:
            self.create_subscription(ActuatorFrame, topics.actuator_frame(name),
                                     lambda msg, n=name: self._on_frame(n, msg), topics.RELIABLE)
        self.lockstep = LockstepStart(self, wait_for, self._publish_sample, lambda: self.k,
                                      self.stall_timeout_s, self._stalled)

    def _on_frame(self, name: str, msg: ActuatorFrame) -> None:
        self.frames.put(name, msg)
        self._try_advance()

    def _try_advance(self) -> None:
        stamp = self.k * self.frame_ns
        if not self.frames.ready(stamp):
            return
        frames = {name: self.frames.take(name, stamp) for name in topics.DRILLING_ACTUATORS}
        if self.k >= self.last_k:       # the frames of the last sample: every node acted on it
            self.status.publish(stamp)
            self.get_logger().info(f"scenario finished after {self.k} frames")
            acked = flush((self.pub_downhole, self.pub_truth, self.pub_surface))
            self.get_logger().info("the readers have the last samples" if acked else
                                   "a reader did not acknowledge the last samples")
            self.finish()
            return
        for name in self.plant.advance(frames["top_drive"].output, frames["block_feed"].output):
            self.status.error(f"{name}: bad frame; holding its last input")
        self.k += 1
        self.progress.frame_done(self.k)           # rig run's progress line
        self._publish_sample()

    def _stalled(self) -> None:
        stamp = self.k * self.frame_ns
        missing = [n for n in topics.DRILLING_ACTUATORS if not self.frames.has(n, stamp)]
        self.status.error(f"lockstep stalled at t = {stamp * 1e-9:.2f} s for "
                          f"{self.stall_timeout_s:.0f} s; no frame from {', '.join(missing)}",
                          fatal=True)
        self.get_logger().error(self.status.last_error)
        self.exit_code = 3
        self.finish()

    def _publish_sample(self) -> None:
        stamp_ns = self.k * self.frame_ns
        stamp = from_ns(stamp_ns)
        self.pub_clock.publish(Clock(clock=stamp))
        surface = SurfaceMeasurement(**self.plant.sensors(SURFACE_CHANNELS))
        downhole = DownholeMeasurement(**self.plant.sensors(DOWNHOLE_CHANNELS))
        truth = DrillingTruth(evaluated=self.plant.evaluated)
        if self.plant.steps is not None:
            for name in TRAJECTORY_FIELDS:
                setattr(truth, name, getattr(self.plant.steps, name).tolist())
        for msg, pub in ((downhole, self.pub_downhole), (truth, self.pub_truth),
                         (surface, self.pub_surface)):
            msg.header.stamp = stamp
            pub.publish(msg)
        self.status.values = {"sim_time_s": stamp_ns * 1e-9, "frame": float(self.k)}
        self.status.tick(stamp_ns)
        self._try_advance()


def main(args=None) -> None:
    sys.exit(run(DrillingPlantNode, args))


if __name__ == "__main__":
    main()
