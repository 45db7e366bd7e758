"""WITS0 gateway node: the rig's record 01 to rig data systems over TCP, once a period
of the samples' stamps (``rig run ... --wits0 [HOST:PORT]``; drill_gateway.wits0, docs/gateways.md).

    python -m drill_gateway.wits0_node --ros-args -p address:=127.0.0.1:11000

Parameters: ``address`` (127.0.0.1:11000: this machine only; port 0 picks a free one),
``period_s`` (1.0: record 01's sampling interval, in rig time), ``well_id`` (item 0101; default the
scenario's name), and the common ones (its well.yaml gives the bit depth at the start).
Subscriptions are best-effort keep-last, so the gateway never holds up the graph. Prints
``WITS0_ADDRESS host:port`` once it serves.
"""
from __future__ import annotations

import sys
from pathlib import Path

from rclpy.clock import Clock, ClockType

from drill_ros.context import common_parameters
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.status import StatusReporter
from drill_gateway.live_rig import follow, live_rig
from drill_gateway.wits0 import DEFAULT_ADDRESS, RecordPacer, Wits0Server, frame

POLLS_PER_PERIOD = 10                   # the latest sample is looked at 10 times a period


class Wits0GatewayNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("wits0_gateway", **node_options)
        config_dir, scenario_path, mode = common_parameters(self, "case2")
        address = self.declare_parameter("address", DEFAULT_ADDRESS).value or DEFAULT_ADDRESS
        period_s = float(self.declare_parameter("period_s", 1.0).value)
        self.well_id = self.declare_parameter("well_id", "").value or Path(scenario_path).stem
        self.status = StatusReporter(self, mode)
        self.server = Wits0Server(address)
        self.live = live_rig(config_dir)
        self.pacer = RecordPacer(period_s)
        follow(self, self.live)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(period_s / POLLS_PER_PERIOD, self._send, clock=steady)
        self.create_timer(1.0, self._tick, clock=steady)
        self.get_logger().info(f"WITS0 record 01 on tcp://{self.server.address}")
        print(f"WITS0_ADDRESS {self.server.address}", flush=True)

    def _send(self) -> None:
        snapshot = self.live.snapshot()
        if snapshot is None or not self.pacer.due(snapshot.stamp_ns):
            return                           # this period has its frame
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
