"""The OPC-UA gateway's address space, plain data: the rig's measurements, estimates,
setpoints and automation level, each bound to a message field (SI) with its engineering
unit and range (docs/gateways.md holds the table this generates).

Names are the D-WIS (Drilling and Wells Interoperability Standards) signal prototypes of
the DDHub semantic model (its DrillingDataSemantics *PrototypeData* nouns:
``DownholePressure``, ``MPDChokePressure``, ``ActiveVolume``, ``MPDPumpFlowRate``,
``SPP``, ``BitDepth``, ...) where one exists (``prototype``), and D-WIS-style words
otherwise (what is measured, without abbreviations or units). A float with a unit is an
OPC UA Part 8 ``AnalogItemType``: its ``EngineeringUnits`` (EUInformation with the UNECE
Recommendation 20 common code) and ``EURange`` (the range in normal operation); every
value is SI.
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
    "kg/m3": Unit("KMQ", "kg/m³", "kilogram per cubic metre"),
    "N": Unit("NEW", "N", "newton"),
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
    prototype: str = ""    # the D-WIS PrototypeData noun the name is, "" for none
    derived: str = ""      # where a field not in the source message comes from, "" for none
    eu_range: tuple[float, float] | None = None   # Part 8 EURange (low, high) in SI, floats

    @property
    def path(self) -> tuple[str, ...]:
        """Browse path under Objects, without namespace indices."""
        return (ROOT, self.folder, self.name) if self.folder else (ROOT, self.name)


def _m(name, field, unit, text, eu_range, prototype="", derived=""):
    return Variable("Measurements", name, "measurement", field, unit, "float", description=text,
                    prototype=prototype, eu_range=eu_range, derived=derived)


def _e(name, field, unit, text, eu_range, prototype=""):
    return Variable("Estimates", name, "estimate", field, unit, "float", description=text,
                    prototype=prototype, eu_range=eu_range)


def _s(name, field, unit, text, eu_range=None, kind="float", prototype=""):
    return Variable("Setpoints", name, "setpoints", field, unit, kind, True, text,
                    prototype=prototype, eu_range=eu_range)


PRESSURE = (0.0, 1.0e8)            # Pa: a deep well's downhole pressure
SURFACE_PRESSURE = (0.0, 3.5e7)    # Pa: the surface equipment's rating (5000 psi ~ 3.4e7)
FLOW = (0.0, 0.1)                  # m^3/s: 6000 L/min
VARIABLES = (
    _m("DownholePressure", "bhp_pa", "Pa", "bottom-hole pressure, gauge, at the reference depth",
       PRESSURE, "DownholePressure"),
    _m("MPDChokePressure", "choke_dp_pa", "Pa", "pressure across the MPD choke",
       SURFACE_PRESSURE, "MPDChokePressure"),
    _m("SPP", "spp_pa", "Pa", "stand-pipe pressure: the mud pump's discharge pressure",
       SURFACE_PRESSURE, "SPP", "the mud pump's frame in force at the sample (output)"),
    _m("DownholeECD", "ecd_kgm3", "kg/m3",
       "equivalent circulating density at the BHP sensor, from the measured BHP",
       (500.0, 3000.0), "DownholeECD", "bhp_pa over g and the sensor's depth (well.yaml)"),
    _m("HookLoad", "hook_load_n", "N",
       "hook load: the travelling block and the elevator's pull (deadline load cell)",
       (0.0, 5.0e6), "HookLoad"),
    _m("HookPosition", "block_position_m", "m", "drill-string position, positive up, 0 at start",
       (-5.0, 35.0), "HookPosition"),
    _m("BitDepth", "bit_depth_m", "m", "bit depth: the start depth less the block's travel",
       (0.0, 1.0e4), "BitDepth", "the start depth (well.yaml) less block_position_m"),
    _m("FlowRateIn", "string_flow_m3s", "m3/s", "flow into the drill string (NaN: pump off)",
       FLOW, "FlowRateIn"),
    _m("FlowRateOut", "return_flow_m3s", "m3/s", "return flow on the choke line (Coriolis)",
       FLOW, "FlowRateOut"),
    _m("ActiveVolume", "pit_volume_m3", "m3", "active pit volume", (0.0, 200.0), "ActiveVolume"),
    _m("TripTankVolume", "trip_tank_volume_m3", "m3",
       "trip tank volume (level sensor; it moves while the well is lined up to it)",
       (0.0, 100.0)),
    _m("MPDPumpFlowRate", "bpp_flow_m3s", "m3/s", "back-pressure pump flow (strokes)",
       (0.0, 0.05), "MPDPumpFlowRate"),
    _e("DownholePressure", "bhp_pa", "Pa", "UKF estimate of the bottom-hole pressure",
       PRESSURE, "DownholePressure"),
    _e("MPDChokePressure", "choke_dp_pa", "Pa", "UKF estimate of the choke pressure",
       SURFACE_PRESSURE, "MPDChokePressure"),
    _e("HookVelocity", "string_velocity_mps", "m/s", "UKF estimate of the string velocity, up",
       (-2.0, 2.0), "HookVelocity"),
    _e("BottomHoleInflux", "bottom_influx_m3s", "m3/s", "estimated influx into the bottom volume",
       (-0.01, 0.01)),
    _s("DownholePressureSetpoint", "bhp_ref_pa", "Pa", "BHP target", PRESSURE),
    _s("DownholePressureBand", "bhp_band_pa", "Pa", "half width of the allowed BHP band",
       (0.0, 2.0e6)),
    _s("MPDChokePressureSetpoint", "choke_dp_ref_pa", "Pa", "choke pressure target",
       SURFACE_PRESSURE),
    _s("MPDChokePressureBand", "choke_dp_band_pa", "Pa",
       "width of the choke pressure band below its target", (0.0, 5.0e6)),
    _s("TripTargetPosition", "block_position_target_m", "m",
       "trip plan: target string position, up", (-5.0, 35.0)),
    _s("TripSpeedLimit", "trip_speed_limit_mps", "m/s", "trip plan: largest string speed",
       (0.0, 2.0)),
    _s("ControllerEnabled", "controller_enabled", None, "false hands back to manual", kind="bool"),
    _s("MudPumpOn", "mud_pump_on", None, "false stops circulation (connection)", kind="bool"),
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
    rows = ["| browse path (under Objects) | topic.field | unit (UNECE) | EURange | D-WIS "
            "prototype | writable |", "| --- | --- | --- | --- | --- | --- |"]
    for v in VARIABLES:
        unit = f"{UNITS[v.unit].symbol} ({UNITS[v.unit].code})" if v.unit else v.kind
        span = f"{v.eu_range[0]:g} .. {v.eu_range[1]:g}" if v.eu_range else "—"
        origin = f"`{topic_of[v.source]}`: {v.derived}" if v.derived else \
            f"`{topic_of[v.source]}.{v.field}`"
        rows.append(f"| `{'/'.join(v.path)}` | {origin} | {unit} | "
                    f"{span} | {v.prototype or '—'} | {'yes' if v.writable else 'no'} |")
    rows.append(f"| `{ROOT}/{LAST_WRITE_RESULT}` | (the gateway: the last write's outcome) | "
                "text | — | — | no |")
    return "\n".join(rows)
