"""Plain-Python state of the operator console (no rclpy here, so it is unit-testable).

* unit conversion at the display edge: the rig is SI throughout; bar and L/min exist
  only in the page and in the form fields the operator types into;
* setpoint requests built from form input: the operator's fields (display units)
  replace the matching fields of the setpoints in force, after a syntactic check
  (numbers, signs). Whether the request is *acceptable* (actuator envelope, pressure
  window) is decided by the supervisor's /set_setpoints service, whose reason the
  console shows — the console never second-guesses it;
* trend buffers with a global sequence number, so the page fetches only new points;
* the latest value of every source, the recent events (operator and protection) with
  acknowledgement, the automation level requested and in force;
* on a multi-stand trip, the trip sheet kept live (drill_core.tripping.sheet_feed, fed the
  rig floor's steps, the measurements and the setpoints, as the report's is).

Everything is guarded by one lock: the rclpy callbacks write, the HTTP threads read.
"""
from __future__ import annotations

import dataclasses
import math
import threading
import time
from collections import deque
from dataclasses import dataclass
from types import SimpleNamespace

from drill_core.automation import AUTOMATION_LEVELS
from drill_core.scenario import SETPOINT_BOOL_FIELDS as BOOL_FIELDS
from drill_core.scenario import SETPOINT_FIELDS
from drill_core.surface_flows import delta_flow_m3s
from drill_core.tripping.sequence import TripStep
from drill_core.tripping.sheet_feed import TripSheetFeed
from drill_core.tripping.trip_sheet import stands_per_hour
from drill_core.units import DISPLAY_UNITS, LPM_PER_M3S, PA_PER_BAR
from drill_core.well import (annulus_pressure_at_depth_pa, build_geometry,
                             equivalent_density_kgm3)

STAND_LENGTH_M = 28.0          # one stand of drill pipe (docs/design.md §8)
TREND_POINTS = 1500            # per series: 150 s at the 10 Hz sensor rate
EVENT_HISTORY = 200
REPEAT_LOOKBACK = 10           # an event identical to one of the newest 10 is counted, not added
STALE_AFTER_S = 3.0
# (source, kind) of the events an operator acknowledges: protection alarms, clamps and
# refusals, and the rig's faults and formation changes (scenario events on /rig/events)
ACK_EVENTS = {("protection", kind) for kind in ("alarm", "clamp", "refusal")} \
    | {("rig", kind) for kind in ("fault", "formation")}


def bar_to_pa(bar: float) -> float:
    return float(bar) * PA_PER_BAR


def pa_to_bar(pa: float) -> float:
    return float(pa) / PA_PER_BAR


def lpm_to_m3s(lpm: float) -> float:
    return float(lpm) / LPM_PER_M3S


def m3s_to_lpm(m3s: float) -> float:
    return float(m3s) * LPM_PER_M3S


# --------------------------------------------------------------------------- form input


@dataclass(frozen=True)
class FormField:
    setpoint: str          # drill_msgs/Setpoints field (SI)
    to_si: object          # display unit -> SI
    label: str             # as shown on the page, with the display unit
    minimum: float         # smallest acceptable value (display unit)
    strictly_above: bool   # True: the value must be > minimum


FORM_FIELDS = {
    "bhp_bar": FormField("bhp_ref_pa", bar_to_pa, "BHP setpoint [bar]", 0.0, False),
    "bhp_band_bar": FormField("bhp_band_pa", bar_to_pa, "BHP band [bar]", 0.0, True),
    "dp_bar": FormField("choke_dp_ref_pa", bar_to_pa, "choke dp setpoint [bar]", 0.0, False),
    "dp_band_bar": FormField("choke_dp_band_pa", bar_to_pa, "choke dp band [bar]", 0.0, True),
    "target_m": FormField("block_position_target_m", float, "trip target position [m]",
                          -math.inf, False),
    "speed_mps": FormField("trip_speed_limit_mps", float, "trip speed limit [m/s]", 0.0, True),
}


class FormError(ValueError):
    """Form input that cannot become a setpoint request; the message says why."""


def parse_number(value, label: str) -> float | None:
    """A number typed by the operator; None for an empty field (= unchanged)."""
    if value is None:
        return None
    if isinstance(value, bool):
        raise FormError(f"{label}: expected a number, got {value!r}")
    if isinstance(value, (int, float)):
        number = float(value)
    else:
        text = str(value).strip().replace(",", ".")
        if not text:
            return None
        try:
            number = float(text)
        except ValueError:
            raise FormError(f"{label}: {value!r} is not a number") from None
    if not math.isfinite(number):
        raise FormError(f"{label}: {value!r} is not a finite number")
    return number


def parse_bool(value, label: str) -> bool | None:
    if value is None or value == "":
        return None
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in ("1", "true", "on", "yes", "enabled"):
        return True
    if text in ("0", "false", "off", "no", "disabled"):
        return False
    raise FormError(f"{label}: {value!r} is not on/off")


def build_request(active: dict | None, form: dict, source: str = "operator") -> dict:
    """SI setpoints to request: ``active`` with the form's fields replaced.

    ``form`` holds display-unit keys of FORM_FIELDS and/or BOOL_FIELDS; empty or absent
    fields keep the value in force. Raises FormError on unknown keys, non-numbers,
    wrong signs, when no setpoints are known yet, or when nothing would change.
    """
    if active is None:
        raise FormError("no setpoints in force yet (waiting for /setpoints from the supervisor)")
    unknown = sorted(set(form) - set(FORM_FIELDS) - set(BOOL_FIELDS))
    if unknown:
        raise FormError(f"unknown field(s) {', '.join(unknown)}; expected "
                        f"{', '.join(list(FORM_FIELDS) + list(BOOL_FIELDS))}")
    request = {name: active.get(name, math.nan) for name in SETPOINT_FIELDS}
    changed = False
    for key, spec in FORM_FIELDS.items():
        number = parse_number(form.get(key), spec.label)
        if number is None:
            continue
        if number < spec.minimum or (spec.strictly_above and number <= spec.minimum):
            relation = ">" if spec.strictly_above else ">="
            raise FormError(f"{spec.label}: {number:g} must be {relation} {spec.minimum:g}")
        request[spec.setpoint] = spec.to_si(number)
        changed |= not _same(request[spec.setpoint], active.get(spec.setpoint))
    for key in BOOL_FIELDS:
        flag = parse_bool(form.get(key), key)
        if flag is None:
            continue
        request[key] = flag
        changed |= flag != bool(active.get(key))
    if not changed:
        raise FormError("nothing to change: the requested values are the ones in force")
    request["controller_enabled"] = bool(request["controller_enabled"])
    request["mud_pump_on"] = bool(request["mud_pump_on"])
    request["source"] = source
    return request


def _same(a, b) -> bool:
    if a is None or b is None:
        return a is b
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def stand_target(active: dict | None, direction: str, stand_length_m: float = STAND_LENGTH_M) -> float:
    """Trip plan target one stand above ("out": pull out) or below ("in": run in) the
    target in force."""
    if active is None:
        raise FormError("no setpoints in force yet (waiting for /setpoints from the supervisor)")
    if direction not in ("out", "in"):
        raise FormError(f"trip direction {direction!r}: expected 'out' (pull out) or 'in' (run in)")
    target = active.get("block_position_target_m", math.nan)
    if not math.isfinite(target):
        target = 0.0
    return target + (stand_length_m if direction == "out" else -stand_length_m)


def describe_changes(active: dict | None, request: dict) -> str:
    """Human-readable summary (display units) of what a request changes."""
    active = active or {}
    parts = []
    for key, spec in FORM_FIELDS.items():
        new, old = request.get(spec.setpoint), active.get(spec.setpoint)
        if new is None or _same(new, old):
            continue
        unit = spec.label.rsplit("[", 1)[-1].rstrip("]")
        name = spec.label.rsplit(" [", 1)[0]
        scale = PA_PER_BAR if unit == "bar" else 1.0
        parts.append(f"{name} {_fmt(old, scale)} -> {_fmt(new, scale)} {unit}")
    for key in BOOL_FIELDS:
        if key in request and bool(request[key]) != bool(active.get(key)):
            parts.append(f"{key} {'on' if request[key] else 'off'}")
    return ", ".join(parts) or "no change"


def _fmt(value, scale: float) -> str:
    if value is None or not math.isfinite(value):
        return "hold"
    return f"{value / scale:.2f}".rstrip("0").rstrip(".")


def level_or_error(level: str) -> str:
    if level not in AUTOMATION_LEVELS:
        raise FormError(f"automation level {level!r}: expected one of {', '.join(AUTOMATION_LEVELS)}")
    return level


# --------------------------------------------------------------------------- JSON helper
def clean(value):
    """JSON-safe copy: NaN/inf become None (JSON has no NaN), tuples become lists."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, deque)):
        return [clean(v) for v in value]
    return value


def _round(value: float, digits: int = 9) -> float | None:
    if value is None or not math.isfinite(value):
        return None
    return float(f"{value:.{digits}g}")


# --------------------------------------------------------------------------- the state
@dataclass(frozen=True)
class Window:
    """Pressure window at the BHP sensor (well.yaml's formation, protection.yaml's margin
    and machine trip speed), SI."""
    pore_pressure_pa: float
    fracture_pressure_pa: float
    pressure_margin_pa: float = 0.0
    trip_speed_max_mps: float = math.inf
    bhp_depth_m: float = math.nan          # vertical depth of the BHP sensor (ECD) [m]
    gravity_mps2: float = 9.81
    shoe_depth_m: float = math.nan         # vertical depth of the casing shoe (ECD) [m]
    node_depth_m: tuple[float, ...] = ()   # the model's annulus nodes D_1..D_n [m]

    @classmethod
    def from_config(cls, config) -> "Window":
        f, p, w = config.well.formation, config.protection, config.well
        depths = build_geometry(w).node_depth_m
        shoe = math.nan if w.casing_shoe_depth_m is None else w.casing_shoe_depth_m
        return cls(f.pore_pressure_pa, f.fracture_pressure_pa, p.pressure_margin_pa,
                   p.trip_speed_max_mps, depths[-1], w.gravity_mps2, shoe, depths)

    def shoe_ecd_kgm3(self, annulus_pressures_pa) -> float | None:
        """The ECD at the casing shoe from the annulus pressures p_1..p_n at the nodes (the
        estimate's: no sensor reads there); None without a shoe or pressures."""
        if not (math.isfinite(self.shoe_depth_m) and annulus_pressures_pa
                and len(annulus_pressures_pa) == len(self.node_depth_m)):
            return None
        pressure = annulus_pressure_at_depth_pa(self.node_depth_m, annulus_pressures_pa,
                                                self.shoe_depth_m)
        return equivalent_density_kgm3(pressure, self.shoe_depth_m, self.gravity_mps2)


class ConsoleState:
    """Everything the page shows. Writers: rclpy callbacks; readers: HTTP threads."""

    def __init__(self, window: Window, trend_points: int = TREND_POINTS, clock=time.monotonic,
                 stand_length_m: float = STAND_LENGTH_M):
        self.window = window
        self.stand_length_m = stand_length_m
        self._clock = clock
        self._lock = threading.RLock()
        self._trend_points = trend_points
        self._seq = 0
        self._trends: dict[str, deque] = {}
        self._latest: dict[str, dict] = {}
        self._received: dict[str, float] = {}
        self._actuators: dict[str, dict] = {}
        self._nodes: dict[str, dict] = {}
        self._events: deque = deque(maxlen=EVENT_HISTORY)
        self._event_id = 0
        self.requested_level: str | None = None     # latched /operator/automation_level
        self.estop: bool | None = None              # latched /operator/emergency_stop
        self._protection_level: str | None = None   # latched /protection/automation_level
        self._protection_estop = False              # latched /protection/emergency_stop
        self._result: dict | None = None            # last operator action and its outcome
        self._pit_start_m3: float | None = None     # the first pit reading
        self._trip_sheet: TripSheetFeed | None = None   # a multi-stand trip's, once its floor speaks
        self._floor_step: TripStep | None = None        # the rig floor's last step

    # ---------------------------------------------------------------- trends
    def add_point(self, series: str, t: float, value: float) -> None:
        if value is None or not math.isfinite(value) or not math.isfinite(t):
            return
        with self._lock:
            self._seq += 1
            buf = self._trends.get(series)
            if buf is None:
                buf = self._trends[series] = deque(maxlen=self._trend_points)
            buf.append((self._seq, round(t, 3), _round(value)))

    def trend(self, series: str) -> list[tuple[float, float]]:
        with self._lock:
            return [(t, v) for _, t, v in self._trends.get(series, ())]

    def trends_since(self, since: int) -> dict[str, list]:
        with self._lock:
            out = {}
            for name, buf in self._trends.items():
                if buf and buf[-1][0] > since:
                    out[name] = [[t, v] for seq, t, v in buf if seq > since]
            return out

    # ---------------------------------------------------------------- sources
    def _touch(self, source: str, values: dict) -> None:
        self._latest[source] = values
        self._received[source] = self._clock()

    def on_measurement(self, t: float, m: dict, stamp_ns: int | None = None) -> None:
        """A measurement at ``t`` [s]; stamped ``stamp_ns`` it also feeds the trip sheet."""
        with self._lock:
            if self._pit_start_m3 is None and math.isfinite(m.get("pit_volume_m3", math.nan)):
                self._pit_start_m3 = m["pit_volume_m3"]
            if self._trip_sheet is not None and stamp_ns is not None:
                self._trip_sheet.measurement(stamp_ns, m["bhp_pa"], m["trip_tank_volume_m3"])
            self._touch("measurement", dict(m, t=t, **self._mpd_view(m)))
            self.add_point("bhp_measured", t, m["bhp_pa"])
            self.add_point("dp_measured", t, m["choke_dp_pa"])
            self.add_point("position_measured", t, m["block_position_m"])
            if m.get("string_flow_valid"):
                self.add_point("flow_measured", t, m["string_flow_m3s"])

    def _mpd_view(self, m: dict) -> dict:
        """What the MPD engineer reads besides the sensors: delta flow (out less all in),
        pit gain since the first reading, ECD at the BHP sensor from the measured BHP."""
        out = {"ecd_kgm3": equivalent_density_kgm3(m["bhp_pa"], self.window.bhp_depth_m,
                                                   self.window.gravity_mps2)}
        if "return_flow_m3s" in m:
            out["delta_flow_m3s"] = delta_flow_m3s(SimpleNamespace(**m)) \
                if m.get("string_flow_valid") else None
        if self._pit_start_m3 is not None and "pit_volume_m3" in m:
            out["pit_gain_m3"] = m["pit_volume_m3"] - self._pit_start_m3
        return out

    def on_truth(self, t: float, m: dict) -> None:
        with self._lock:
            self._touch("truth", dict(m, t=t))
            self.add_point("bhp_truth", t, m["bhp_pa"])
            self.add_point("velocity_truth", t, m["string_velocity_mps"])
            self.add_point("position_truth", t, m["string_position_m"])

    def on_estimate(self, t: float, m: dict) -> None:
        with self._lock:
            self._touch("estimate", dict(
                m, t=t, shoe_ecd_kgm3=self.window.shoe_ecd_kgm3(m.get("annulus_pressures_pa"))))
            self.add_point("bhp_estimate", t, m["bhp_pa"])
            self.add_point("dp_estimate", t, m["choke_dp_pa"])
            self.add_point("velocity_estimate", t, m["string_velocity_mps"])
            if m.get("string_position_m") is not None:
                self.add_point("position_estimate", t, m["string_position_m"])
            if m.get("nis_dof"):
                self.add_point("nis", t, m["nis"])

    def on_nmpc(self, t: float, m: dict) -> None:
        with self._lock:
            self._touch("nmpc", dict(m, t=t))
            self.add_point("solve_time", t, m["solve_time_s"])
            self.add_point("bhp_reference", t, m["bhp_ref_pa"])

    def on_setpoints(self, m: dict) -> None:
        with self._lock:
            self._touch("setpoints", dict(m))
            if self._trip_sheet is not None:
                self._trip_sheet.reference(m["bhp_ref_pa"], m["bhp_band_pa"])

    def on_floor(self, stamp_ns: int, step: TripStep, start_sheet=None) -> None:
        """The rig floor's step for the frame from ``stamp_ns``; ``start_sheet()`` makes the
        trip sheet's feed (drill_core.tripping.sheet_feed.TripSheetFeed) at the first one."""
        with self._lock:
            if self._trip_sheet is None and start_sheet is not None:
                self._trip_sheet = start_sheet()
                sp = self._latest.get("setpoints")
                if sp is not None:
                    self._trip_sheet.reference(sp["bhp_ref_pa"], sp["bhp_band_pa"])
            self._floor_step = step
            if self._trip_sheet is not None:
                self._trip_sheet.floor(stamp_ns, step)

    def trip_sheet(self) -> dict | None:
        """The live trip sheet (SI): the programme, the closed rows, stands per hour, the
        running trip-tank difference, the floor's phase and stand; None before a trip."""
        with self._lock:
            feed = self._trip_sheet
            if feed is None:
                return None
            sheet, step = feed.sheet, self._floor_step
            return {"direction": sheet.programme.direction, "stands": sheet.programme.stands,
                    "stand_length_m": sheet.programme.stand_length_m,
                    "discrepancy_alarm_m3": sheet.programme.discrepancy_alarm_m3,
                    "rows": [dataclasses.asdict(r) for r in sheet.rows],
                    "stands_per_hour": stands_per_hour(sheet.rows) if sheet.rows else None,
                    "cumulative_gain_m3": sheet.cumulative_gain_m3,
                    "alarms": [n.code for n in feed.alarms],
                    "phase": step.phase if step else None, "stand": step.stand if step else None}

    def on_frame(self, name: str, t: float, m: dict) -> None:
        with self._lock:
            self._actuators[name] = dict(m, t=t)
            self._received[f"actuator/{name}"] = self._clock()
            self.add_point(f"{name}_command", t, m["command"])
            if m.get("output"):
                self.add_point(f"{name}_output", t, m["output"][-1])

    def on_status(self, name: str, m: dict) -> None:
        with self._lock:
            self._nodes[name] = dict(m)
            self._received[f"node/{name}"] = self._clock()

    def on_level(self, level: str) -> None:
        with self._lock:
            self.requested_level = level

    def on_estop(self, engaged: bool) -> None:
        with self._lock:
            self.estop = bool(engaged)

    def on_level_in_force(self, level: str) -> None:
        with self._lock:
            self._protection_level = level

    def on_estop_in_force(self, engaged: bool) -> None:
        with self._lock:
            self._protection_estop = bool(engaged)

    def active_setpoints(self) -> dict | None:
        with self._lock:
            sp = self._latest.get("setpoints")
            return dict(sp) if sp is not None else None

    def latest(self, source: str) -> dict | None:
        with self._lock:
            value = self._latest.get(source)
            return dict(value) if value is not None else None

    # ---------------------------------------------------------------- events
    def on_event(self, source: str, t: float, kind: str, code: str, text: str,
                 accepted: bool) -> dict:
        """Add an event (``code``: drill_core.event_codes), or count a repeat of an identical
        one among the newest few (moved to the end), so a clamp repeated every command
        period does not flood the list."""
        with self._lock:
            key = (source, code, text)
            for event in list(self._events)[-REPEAT_LOOKBACK:]:
                if (event["source"], event["code"], event["text"]) == key:
                    self._events.remove(event)
                    event.update(count=event["count"] + 1, t=t, wall=time.time())
                    self._events.append(event)
                    return dict(event)
            self._event_id += 1
            event = {"id": self._event_id, "t": t, "wall": time.time(), "source": source,
                     "kind": kind, "code": code, "text": text, "accepted": bool(accepted), "count": 1,
                     "needs_ack": (source, kind) in ACK_EVENTS, "acked": False}
            self._events.append(event)
            return dict(event)

    def acknowledge(self, event_id: int | None = None) -> list[dict]:
        """Acknowledge one event (by id) or, with None, every unacknowledged one."""
        with self._lock:
            done = []
            for event in self._events:
                if event["needs_ack"] and not event["acked"] and event_id in (None, event["id"]):
                    event["acked"] = True
                    done.append(dict(event))
            if event_id is not None and not done:
                known = any(e["id"] == event_id for e in self._events)
                raise FormError(f"event #{event_id} " + ("needs no acknowledgement or is already acknowledged"
                                                         if known else "is not in the recent events"))
            return done

    def events(self) -> list[dict]:
        with self._lock:
            return [dict(e) for e in self._events]

    def unacknowledged(self) -> int:
        with self._lock:
            return sum(1 for e in self._events if e["needs_ack"] and not e["acked"])

    # ---------------------------------------------------------------- actions
    def set_result(self, action: str, accepted: bool, reason: str = "", detail: str = "") -> dict:
        with self._lock:
            self._result = {"action": action, "accepted": bool(accepted), "reason": reason,
                            "detail": detail, "wall": time.time()}
            return dict(self._result)

    # ---------------------------------------------------------------- level
    def level_in_force(self) -> dict:
        """The automation level in force: what the protection layer applies (its latched
        topics) while it is alive (its status fresh), else the latched request, else its
        default."""
        with self._lock:
            now = self._clock()
            fresh = now - self._received.get("node/protection", -1e9) < STALE_AFTER_S
            estop = bool(self.estop) or (fresh and self._protection_estop)
            if fresh and self._protection_level in AUTOMATION_LEVELS:
                level = self._protection_level
                source = "protection (under the emergency stop)" if self._protection_estop \
                    else "protection"
            elif self.requested_level in AUTOMATION_LEVELS:
                level, source = self.requested_level, "latched request"
            else:
                level, source = "closed_loop", "protection default (no request yet)"
            return {"level": level, "source": source, "requested": self.requested_level,
                    "emergency_stop": estop, "emergency_stop_requested": self.estop}

    # ---------------------------------------------------------------- snapshot
    def snapshot(self, since: int = 0) -> dict:
        """JSON-safe view for GET /api/state: trends with sequence number > ``since``."""
        with self._lock:
            now = self._clock()
            ages = {k: round(now - v, 2) for k, v in self._received.items()}
            out = {
                "seq": self._seq,
                "trends": self.trends_since(since),
                "measurement": self._latest.get("measurement"),
                "truth": self._latest.get("truth"),
                "estimate": self._latest.get("estimate"),
                "nmpc": self._latest.get("nmpc"),
                "setpoints": self._latest.get("setpoints"),
                "actuators": self._actuators,
                "nodes": self._nodes,
                "ages_s": ages,
                "stale_after_s": STALE_AFTER_S,
                "window": {"pore_pressure_pa": self.window.pore_pressure_pa,
                           "fracture_pressure_pa": self.window.fracture_pressure_pa,
                           "pressure_margin_pa": self.window.pressure_margin_pa,
                           "trip_speed_max_mps": self.window.trip_speed_max_mps},
                "stand_length_m": self.stand_length_m,
                "display_units": DISPLAY_UNITS,
                "automation": self.level_in_force(),
                "levels": list(AUTOMATION_LEVELS),
                "events": [dict(e) for e in list(self._events)[-50:]],
                "unacknowledged": sum(1 for e in self._events if e["needs_ack"] and not e["acked"]),
                "result": self._result,
                "trip_sheet": self.trip_sheet(),
            }
            return clean(out)
