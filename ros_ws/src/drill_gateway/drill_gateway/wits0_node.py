"""WITS0 gateway node: the rig's record 01 to rig data systems over TCP, once a period
(``rig run ... --wits0 [HOST:PORT]``; drill_gateway.wits0, docs/gateways.md).

    python -m drill_gateway.wits0_node --ros-args -p address:=127.0.0.1:11000

Parameters: ``address`` (127.0.0.1:11000: this machine only; port 0 picks a free one),
``period_s`` (1.0: record 01's sampling interval), ``well_id`` (item 0101; default the
scenario's name), and the common ones (its well.yaml gives the bit depth at the start).
Subscriptions are best-effort keep-last, so the gateway never holds up the graph. Prints
``WITS0_ADDRESS host:port`` once it serves.
"""
from __future__ import annotations

import sys
from pathlib import Path

from drill_msgs.msg import ActuatorFrame, RigMeasurement
from rclpy.clock import Clock, ClockType

from drill_bag.well_log import FRAME_ACTUATORS, RigSnapshot, stamp_ns
from drill_core.config import Well, load_section
from drill_core.well import build_geometry
from drill_hmi import console
from drill_ros import topics
from drill_ros.context import common_parameters
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.status import StatusReporter
from drill_gateway.wits0 import DEFAULT_ADDRESS, Wits0Server, frame


class Wits0GatewayNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("wits0_gateway", **node_options)
        config_dir, scenario_path, mode = common_parameters(self, "case2")
        address = self.declare_parameter("address", DEFAULT_ADDRESS).value or DEFAULT_ADDRESS
        period_s = float(self.declare_parameter("period_s", 1.0).value)
        self.well_id = self.declare_parameter("well_id", "").value or Path(scenario_path).stem
        self.bit_depth_m = build_geometry(
            load_section(Well, Path(config_dir) / "well.yaml")).bit_depth_m
        self.status = StatusReporter(self, mode)
        self.server = Wits0Server(address)
        self._measurement: RigMeasurement | None = None
        self._frames: dict[str, ActuatorFrame] = {}
        self._pit_start_m3: float | None = None
        self._last_sent_ns = -1
        self.create_subscription(RigMeasurement, topics.MEASUREMENT, self._on_measurement,
                                 console.DISPLAY)
        for actuator in FRAME_ACTUATORS:
            self.create_subscription(ActuatorFrame, topics.actuator_frame(actuator),
                                     lambda m, a=actuator: self._frames.__setitem__(a, m),
                                     console.DISPLAY)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(period_s, self._send, clock=steady)
        self.create_timer(1.0, self._tick, clock=steady)
        self.get_logger().info(f"WITS0 record 01 on tcp://{self.server.address}")
        print(f"WITS0_ADDRESS {self.server.address}", flush=True)

    def _on_measurement(self, msg: RigMeasurement) -> None:
        if self._pit_start_m3 is None:
            self._pit_start_m3 = msg.pit_volume_m3
        self._measurement = msg

    def _send(self) -> None:
        m = self._measurement
        if m is None or stamp_ns(m) == self._last_sent_ns:
            return                           # nothing new since the last frame
        self._last_sent_ns = stamp_ns(m)
        snapshot = RigSnapshot(m, dict(self._frames), self._last_sent_ns, self.bit_depth_m,
                               self._pit_start_m3)
        self.server.send(frame(snapshot, self.well_id))

    def _tick(self) -> None:
        self.status.values = {"port": float(self.server.port),
                              "clients": float(self.server.clients),
                              "frames_sent": float(self.server.frames_sent)}
        self.status.tick(self.get_clock().now().nanoseconds)

    def destroy_node(self):
        self.server.close()
        return super().destroy_node()


def main(args=None) -> None:
    sys.exit(run(Wits0GatewayNode, args))


if __name__ == "__main__":
    main()
