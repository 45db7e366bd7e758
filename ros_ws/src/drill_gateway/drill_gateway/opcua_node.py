"""OPC-UA gateway node: the rig's measurements, estimates, setpoints and automation level
on an OPC-UA server under the D-WIS signal-prototype names, as Part 8 analog items
(``rig run ... --opcua [ENDPOINT]``; docs/gateways.md).

    python -m drill_gateway.opcua_node --ros-args -p endpoint:=opc.tcp://127.0.0.1:4840/drill-rig

Parameters: ``endpoint`` (opc.tcp://127.0.0.1:4840/drill-rig: this machine only),
``security_dir`` (a directory of ``rig certs``: Basic256Sha256, users and roles; needed
for an endpoint other machines reach, docs/security.md), ``service_timeout_s`` (5 s). Setpoint writes go through the supervisor's validating
/set_setpoints service and the automation level out on /operator/automation_level, both
through the console's operator link (drill_hmi.console.OperatorLink: the same
requests, the same recorded operator events, source "opcua"). Display subscriptions are
best-effort keep-last (latched topics: as published), so the gateway never holds up the
graph. Prints ``OPCUA_URL <endpoint>`` once it serves.
"""
from __future__ import annotations

import logging
import sys
import threading
from pathlib import Path

from drill_msgs.msg import Setpoints, StateEstimate
from std_msgs.msg import String

from drill_bag.well_log import BY_MNEMONIC, LiveRig, stamp_ns
from drill_hmi import console
from drill_core.access import SecurityDir
from drill_core.config import Well, load_section
from drill_core.well import build_geometry, equivalent_density_kgm3
from drill_ros import topics
from drill_ros.context import common_parameters
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.status import StatusReporter
from drill_gateway import opcua_writes
from drill_gateway.live_rig import follow
from drill_gateway.opcua_gateway import DEFAULT_ENDPOINT, Gateway
from drill_gateway.opcua_names import by_source


def source_topics() -> dict[str, str]:
    """The topic each source of drill_gateway.opcua_names.SOURCES is read from (the
    gateway's subscriptions in drill_ros.graph)."""
    return {"measurement": topics.MEASUREMENT, "estimate": topics.ESTIMATE,
            "setpoints": topics.SETPOINTS, "level": topics.LEVEL_IN_FORCE}


def fields(msg, source: str) -> dict:
    """The gateway's fields of a message of ``source`` (those it carries): field -> value."""
    return {v.field: getattr(msg, v.field) for v in by_source(source) if not v.derived}


class MeasuredView:
    """The measurement's variables, the derived ones included (drill_gateway.opcua_names
    ``derived``): SPP from the mud pump's frame in force, the bit depth from the block's
    travel (drill_bag.well_log's channels), the ECD from the measured BHP."""

    def __init__(self, well: Well):
        self.live = LiveRig(well)
        self.sensor_depth_m = build_geometry(well).node_depth_m[-1]
        self.gravity_mps2 = well.gravity_mps2

    def fields(self) -> dict:
        """The variables of the newest sensor sample (``live``'s)."""
        snapshot = self.live.snapshot()
        m = snapshot.measurement
        return {**fields(m, "measurement"),
                "spp_pa": BY_MNEMONIC["SPPA"].value_si(snapshot),
                "bit_depth_m": BY_MNEMONIC["DBTM"].value_si(snapshot),
                "ecd_kgm3": equivalent_density_kgm3(m.bhp_pa, self.sensor_depth_m,
                                                    self.gravity_mps2)}


class OpcuaGatewayNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("opcua_gateway", **node_options)
        endpoint = self.declare_parameter("endpoint", DEFAULT_ENDPOINT).value or DEFAULT_ENDPOINT
        timeout_s = float(self.declare_parameter("service_timeout_s", 5.0).value)
        config_dir, _, mode = common_parameters(self, "case2")
        self.view = MeasuredView(load_section(Well, Path(config_dir) / "well.yaml"))
        security_dir = self.declare_parameter("security_dir", "").value
        logging.getLogger("asyncua").setLevel(logging.WARNING)
        self.link = console.OperatorLink(self, timeout_s, source="opcua")
        self.status = StatusReporter(self, mode)
        self._active: dict | None = None           # the setpoints in force (latched /setpoints)
        self._lock = threading.Lock()
        security = SecurityDir(Path(security_dir)) if security_dir else None
        self.gateway = Gateway(endpoint, self._write_setpoint, self._write_level, security,
                               on_refused=lambda text: self.link.refuse("OPC-UA write", text))

        where = source_topics()
        sub = self.create_subscription
        follow(self, self.view.live,     # the measurement and the frames derived ones read
               lambda m: self.gateway.update("measurement", self.view.fields(), stamp_ns(m)))
        sub(StateEstimate, where["estimate"],
            lambda m: self.gateway.update("estimate", fields(m, "estimate"), stamp_ns(m)),
            console.DISPLAY)
        sub(Setpoints, where["setpoints"], self._on_setpoints, topics.LATCHED)
        sub(String, where["level"], lambda m: self.gateway.update("level", fields(m, "level")),
            topics.LATCHED)
        self.create_timer(1.0, self._tick)
        self.gateway.start()         # the subscriptions are in the graph while it starts
        self.get_logger().info(f"OPC-UA gateway on {endpoint}")
        print(f"OPCUA_URL {endpoint}", flush=True)

    def _on_setpoints(self, msg: Setpoints) -> None:
        with self._lock:
            self._active = console.setpoints_to_dict(msg)
        self.gateway.update("setpoints", fields(msg, "setpoints"))

    # called by the gateway in a worker thread, while this node spins
    def _write_setpoint(self, variable, value) -> opcua_writes.Outcome:
        with self._lock:
            active = dict(self._active) if self._active is not None else None
        return opcua_writes.write_setpoint(variable, value, active, self.link.request_setpoints)

    def _write_level(self, value) -> opcua_writes.Outcome:
        return opcua_writes.write_level(value, self.link.set_level)

    def _tick(self) -> None:
        self.status.values = {f"writes_{k}": float(v) for k, v in self.gateway.writes.items()}
        self.status.tick(self.get_clock().now().nanoseconds)

    def destroy_node(self):
        self.gateway.stop()
        return super().destroy_node()


def main(args=None) -> None:
    sys.exit(run(OpcuaGatewayNode, args))


if __name__ == "__main__":
    main()
