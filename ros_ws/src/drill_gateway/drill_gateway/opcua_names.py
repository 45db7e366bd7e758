"""The OPC-UA gateway's address space, plain data: D-WIS-style names for the rig's
measurements, estimates, setpoints and automation level, each bound to a message field
(SI) with its engineering unit (docs/gateways.md holds the table this generates).

Names follow the D-WIS (Drilling and Wells Interoperability Standards) style: what is
measured, in words, without abbreviations or units (``BottomHolePressure``, not
``bhp_pa``); the unit is the variable's ``EngineeringUnits`` property (OPC UA Part 8
EUInformation with the UNECE Recommendation 20 common code), and every value is SI.
"""
from __future__ import annotations

from dataclasses import dataclass

NAMESPACE_URI = "urn:drill-rig:gateway"     # the rig's namespace; clients look its index up
ROOT = "Rig"                                # the object under Objects holding everything
UNECE_NAMESPACE = "http://www.opcfoundation.org/UA/units/un/cefact"

# the messages the gateway reads (drill_gateway.opcua_node.source_topics binds each to its
# topic; the topic's type is the graph's)
SOURCES = ("measurement", "estimate", "setpoints", "level")


@dataclass(frozen=True)
class Unit:
    code: str          # UNECE Rec. 20 common code
    symbol: str        # display name
    name: str          # description

    @property
    def unit_id(self) -> int:
        """OPC UA Part 8 UnitId: the common code's (up to 3) ASCII characters, big-endian."""
        value = 0
        for char in self.code:
            value = (value << 8) | ord(char)
        return value


UNITS = {
    "Pa": Unit("PAL", "Pa", "pascal"),
    "m": Unit("MTR", "m", "metre"),
    "m/s": Unit("MTS", "m/s", "metre per second"),
    "m3/s": Unit("MQS", "m³/s", "cubic metre per second"),
    "m3": Unit("MTQ", "m³", "cubic metre"),
}


@dataclass(frozen=True)
class Variable:
    folder: str        # "Measurements", "Estimates", "Setpoints" or "" (directly under Rig)
    name: str          # D-WIS-style browse name
    source: str        # key of SOURCES
    field: str         # field of the source message ("data" for std_msgs/String)
    unit: str | None   # key of UNITS; None for flags and text
    kind: str          # "float", "bool" or "text"
    writable: bool = False
    description: str = ""  # the node's Description attribute

    @property
    def path(self) -> tuple[str, ...]:
        """Browse path under Objects, without namespace indices."""
        return (ROOT, self.folder, self.name) if self.folder else (ROOT, self.name)


def _m(name, field, unit, text):
    return Variable("Measurements", name, "measurement", field, unit, "float", description=text)


def _e(name, field, unit, text):
    return Variable("Estimates", name, "estimate", field, unit, "float", description=text)


def _s(name, field, unit, text, kind="float"):
    return Variable("Setpoints", name, "setpoints", field, unit, kind, True, text)


VARIABLES = (
    _m("BottomHolePressure", "bhp_pa", "Pa",
       "bottom-hole pressure, gauge, at the reference depth"),
    _m("ChokeDifferentialPressure", "choke_dp_pa", "Pa", "pressure across the MPD choke"),
    _m("HookPosition", "block_position_m", "m", "drill-string position, positive up, 0 at start"),
    _m("FlowRateIn", "string_flow_m3s", "m3/s", "flow into the drill string (NaN: pump off)"),
    _m("FlowRateOut", "return_flow_m3s", "m3/s", "return flow on the choke line (Coriolis)"),
    _m("ActivePitVolume", "pit_volume_m3", "m3", "active pit volume"),
    _m("BackPressurePumpFlowRate", "bpp_flow_m3s", "m3/s", "back-pressure pump flow (strokes)"),
    _e("BottomHolePressure", "bhp_pa", "Pa", "UKF estimate of the bottom-hole pressure"),
    _e("ChokeDifferentialPressure", "choke_dp_pa", "Pa", "UKF estimate of the choke pressure"),
    _e("HookVelocity", "string_velocity_mps", "m/s", "UKF estimate of the string velocity, up"),
    _e("BottomHoleInflux", "bottom_influx_m3s", "m3/s", "estimated influx into the bottom volume"),
    _s("BottomHolePressureSetpoint", "bhp_ref_pa", "Pa", "BHP target"),
    _s("BottomHolePressureBand", "bhp_band_pa", "Pa", "half width of the allowed BHP band"),
    _s("ChokeDifferentialPressureSetpoint", "choke_dp_ref_pa", "Pa", "choke pressure target"),
    _s("ChokeDifferentialPressureBand", "choke_dp_band_pa", "Pa",
       "width of the choke pressure band below its target"),
    _s("TripTargetPosition", "block_position_target_m", "m",
       "trip plan: target string position, up"),
    _s("TripSpeedLimit", "trip_speed_limit_mps", "m/s", "trip plan: largest string speed"),
    _s("ControllerEnabled", "controller_enabled", None, "false hands back to manual", "bool"),
    _s("MudPumpOn", "mud_pump_on", None, "false stops circulation (connection)", "bool"),
    Variable("", "AutomationLevel", "level", "data", None, "text", True,
             "in force (protection); write manual, advisory or closed_loop to request one"),
)
LAST_WRITE_RESULT = "LastWriteResult"   # Rig/LastWriteResult: the last write's outcome, text


def by_source(source: str) -> tuple[Variable, ...]:
    if source not in SOURCES:
        raise ValueError(f"source {source!r} is not one of {', '.join(SOURCES)}")
    return tuple(v for v in VARIABLES if v.source == source)


def markdown_table(topic_of: dict[str, str]) -> str:
    """docs/gateways.md's name table; ``topic_of``: source key -> its topic."""
    rows = ["| browse path (under Objects) | topic.field | unit (UNECE) | writable |",
            "| --- | --- | --- | --- |"]
    for v in VARIABLES:
        unit = f"{UNITS[v.unit].symbol} ({UNITS[v.unit].code})" if v.unit else v.kind
        rows.append(f"| `{'/'.join(v.path)}` | `{topic_of[v.source]}.{v.field}` | {unit} | "
                    f"{'yes' if v.writable else 'no'} |")
    rows.append(f"| `{ROOT}/{LAST_WRITE_RESULT}` | (the gateway: the last write's outcome) | "
                "text | no |")
    return "\n".join(rows)
