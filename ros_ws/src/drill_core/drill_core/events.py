"""Scenario events: what happens to the rig during a run, as opposed to what an operator
asks of it (the schedule's setpoints, drill_core.scenario). Sensor and actuator faults
and changes of the formation, each at a time, some for a duration (docs/design.md §8).

Plain data, validated like every scenario field against one table, ``EVENT_KINDS``. The
plant applies the sensor and formation events (drill_plant.sensor_faults, the plant's
parameters), each actuator its own faults, and the plant announces every event on
/rig/events; no estimator or controller sees them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drill_core.schema import FieldError, param, range_text

ACTUATORS = ("drawworks", "choke", "bpp", "mud_pump")    # the rig's actuators, plant input order
# The measured channels (drill_msgs/RigMeasurement's value fields) and their SI units.
SENSOR_UNITS = {"block_position_m": "m", "choke_dp_pa": "Pa", "bhp_pa": "Pa",
                "string_flow_m3s": "m^3/s", "return_flow_m3s": "m^3/s", "pit_volume_m3": "m^3",
                "bpp_flow_m3s": "m^3/s", "hook_load_n": "N",
                "trip_tank_volume_m3": "m^3"}
SENSOR_CHANNELS = tuple(SENSOR_UNITS)

SINGLE = "single"        # acts on one sample (the first at or after time_s)
STEP = "step"            # a lasting change from time_s on (a duration is refused)
SPAN = "span"            # from time_s for duration_s (required)
UNTIL = "until"          # from time_s for duration_s, or to the end of the run if absent


@dataclass(frozen=True)
class EventKind:
    """One kind of event: what it may target, what its value means, how long it lasts."""
    targets: tuple[str, ...]                  # allowed targets; () takes none
    value: tuple[str, float, float] | None    # (unit, lowest, highest), None: takes no value
    timing: str                               # SINGLE, STEP, SPAN or UNTIL
    owner: str                                # who applies it: "plant" or "actuator"
    category: str                             # "formation" or "fault" (/rig/events' kind)
    doc: str


_SIGNED = ("unit of the channel", -1.0e9, 1.0e9)
EVENT_KINDS = {
    "pore_pressure": EventKind((), ("Pa", 0.0, 5.0e8), STEP, "plant", "formation",
                               "the formation's pore pressure steps to value (a kick zone)"),
    "fracture_pressure": EventKind((), ("Pa", 0.0, 5.0e8), STEP, "plant", "formation",
                                   "the fracture pressure steps to value (a weak zone)"),
    "choke_plugging": EventKind((), ("1", 0.0, 1.0), STEP, "plant", "fault",
                                "the choke's valve coefficient becomes value times the clean one"),
    "dropout": EventKind(SENSOR_CHANNELS, None, SPAN, "plant", "fault", "the channel reads NaN (no sample)"),
    "frozen": EventKind(SENSOR_CHANNELS, None, SPAN, "plant", "fault", "the channel repeats its last value"),
    "bias": EventKind(SENSOR_CHANNELS, _SIGNED, SPAN, "plant", "fault", "value is added to the channel"),
    "drift": EventKind(SENSOR_CHANNELS, ("unit of the channel per s", -1.0e9, 1.0e9), SPAN, "plant", "fault",
                       "value times the time since the start is added to the channel"),
    "noise_burst": EventKind(SENSOR_CHANNELS, ("unit of the channel", 0.0, 1.0e9), SPAN, "plant", "fault",
                             "extra Gaussian noise of standard deviation value"),
    "nan": EventKind(SENSOR_CHANNELS, None, SINGLE, "plant", "fault", "one sample reads NaN"),
    "inf": EventKind(SENSOR_CHANNELS, None, SINGLE, "plant", "fault", "one sample reads +inf"),
    "spike": EventKind(SENSOR_CHANNELS, _SIGNED, SINGLE, "plant", "fault", "value is added to one sample"),
    "stuck": EventKind(ACTUATORS, None, UNTIL, "actuator", "fault",
                       "the output freezes where it is (choke stuck, drawworks brake set)"),
    "trip": EventKind(("bpp", "mud_pump"), None, UNTIL, "actuator", "fault",
                      "the pump stops whatever it is commanded (spins down through its lag)"),
}


@dataclass(frozen=True)
class ScenarioEvent:
    """One event of a scenario's ``events`` list (SI)."""
    time_s: float = param("s", 0.0, 1.0e6)
    kind: str = param(choices=tuple(EVENT_KINDS))
    target: str = param(default="", doc="sensor channel or actuator, per kind (EVENT_KINDS)")
    value: float = param("SI", -1.0e12, 1.0e12, default=math.nan, doc="per kind (EVENT_KINDS)")
    duration_s: float = param("s", 0.0, 1.0e6, lo_open=True, default=math.nan)

    def validate(self) -> None:
        spec = EVENT_KINDS[self.kind]
        if spec.targets and self.target not in spec.targets:
            raise FieldError("target", f"value {self.target!r} is not one of "
                                       f"{', '.join(spec.targets)} (event {self.kind})")
        if not spec.targets and self.target:
            raise FieldError("target", f"event {self.kind} takes no target")
        if spec.value is None and not math.isnan(self.value):
            raise FieldError("value", f"event {self.kind} takes no value")
        if spec.value is not None:
            unit, lo, hi = spec.value
            span = range_text({"lo": lo, "hi": hi, "unit": unit})
            if math.isnan(self.value):
                raise FieldError("value", f"missing: event {self.kind} needs a value in {span}")
            if not lo <= self.value <= hi:
                raise FieldError("value", f"value {self.value} must lie in {span} "
                                          f"(event {self.kind})")
        if spec.timing == SPAN and math.isnan(self.duration_s):
            raise FieldError("duration_s", f"missing: event {self.kind} lasts a duration")
        if spec.timing in (SINGLE, STEP) and not math.isnan(self.duration_s):
            raise FieldError("duration_s", f"event {self.kind} takes no duration "
                                           f"({'one sample' if spec.timing == SINGLE else 'a lasting change'})")

    @property
    def end_s(self) -> float:
        """When it stops acting (inf: lasts to the end of the run)."""
        return math.inf if math.isnan(self.duration_s) else self.time_s + self.duration_s

    def active(self, time_s: float) -> bool:
        """Whether a SPAN / UNTIL event acts at ``time_s``."""
        return self.time_s <= time_s + 1e-9 and time_s + 1e-9 < self.end_s

    def describe(self) -> str:
        """'bhp_pa dropout for 20 s', 'pore_pressure to 6.9e+07 Pa', ... (SI)."""
        spec = EVENT_KINDS[self.kind]
        words = [w for w in (self.target, self.kind) if w]
        if spec.value is not None:
            unit = spec.value[0]
            words.append(("to " if spec.timing == STEP else "") + f"{self.value:g}"
                         + ("" if unit == "1" or unit.startswith("unit") else f" {unit}"))
        if not math.isnan(self.duration_s):
            words.append(f"for {self.duration_s:g} s")
        return " ".join(words)


def of_owner(events, owner: str, target: str | None = None) -> tuple[ScenarioEvent, ...]:
    """The events ``owner`` ("plant" or "actuator") applies (for one target if given)."""
    return tuple(e for e in events if EVENT_KINDS[e.kind].owner == owner
                 and (target is None or e.target == target))
