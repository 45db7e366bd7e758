"""Scenario files (config/scenarios/*.yaml): initial operating point, controller,
configuration overrides, a timed schedule of setpoints, or of commands for the
``open_loop`` controller (drill_core.open_loop), and events that happen to the rig
(faults, formation changes: drill_core.events) and the operator's actions (emergency stop,
automation level: drill_core.operator_actions) (docs/design.md §8).

A schedule entry changes only the fields it names; the rest carry over. Times are
simulated seconds from the start of the run.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

from drill_core.config import ConfigError, RigConfig, load_rig
from drill_core.yaml_files import load_yaml, merge
from drill_core.events import ScenarioEvent
from drill_core.mismatch import Mismatch, resolve
from drill_core.operator_actions import OperatorAction
from drill_core.open_loop import OpenLoopPlan, start_command
from drill_core.schema import FieldError, build, param
from drill_core.tripping.programme import TripProgramme

_NAN = float("nan")
SCENARIO_KINDS = ("tripping", "drilling")    # a scenario file's ``kind`` (absent: tripping)
TRUTH_KEY = "truth"     # the plant's mismatch (drill_core.mismatch), read by the plant's side only


@dataclass(frozen=True)
class Initial:
    """Steady operating point the run starts from."""
    circulation_m3s: float = param("m^3/s", 0.0, 0.1, doc="0 = mud pump off")
    choke_dp_pa: float = param("Pa", 0.0, 1.0e7)
    bpp_flow_m3s: float = param("m^3/s", 0.0, 0.1)


@dataclass(frozen=True)
class SetpointChange:
    """Setpoints (closed loop) or open-loop commands (controller ``open_loop``,
    drill_core.open_loop) changed at ``time_s``; absent fields keep their previous value."""
    time_s: float = param("s", 0.0, 1.0e6)
    bhp_ref_pa: float = param("Pa", 0.0, 5.0e8, default=_NAN)
    bhp_band_pa: float = param("Pa", 0.0, 1.0e7, lo_open=True, default=_NAN)
    choke_dp_ref_pa: float = param("Pa", 0.0, 1.0e8, default=_NAN)
    choke_dp_band_pa: float = param("Pa", 0.0, 1.0e7, lo_open=True, default=_NAN)
    choke_dp_band_upper_pa: float = param(
        "Pa", 0.0, 1.0e9, default=_NAN,
        doc="width of the choke-dp band above its target; 0: choke_dp_band_pa (symmetric)")
    block_position_target_m: float = param("m", -100.0, 100.0, default=_NAN)
    trip_speed_limit_mps: float = param("m/s", 0.0, 5.0, lo_open=True, default=_NAN)
    controller_enabled: bool | None = param(default=None)
    mud_pump_on: bool | None = param(default=None)
    block_speed_mps: float = param("m/s", 0.0, 5.0, lo_open=True, default=_NAN,
                                   doc="open loop: cruise speed of the block reference")
    block_acceleration_mps2: float = param("m/s^2", 0.0, 5.0, lo_open=True, default=_NAN,
                                           doc="open loop: acceleration of the block reference")
    bpp_flow_m3s: float = param("m^3/s", 0.0, 0.1, default=_NAN,
                                doc="open loop: back-pressure pump flow")
    bpp_ramp_s: float = param("s", 0.0, 1.0e4, default=_NAN,
                              doc="open loop: ramp time to this entry's bpp_flow_m3s (absent: a step)")
    choke_opening: float = param("1", 0.0, 1.0, default=_NAN,
                                 doc="open loop: manual choke opening (choke panel in manual)")
    choke_flow_ref_m3s: float = param("m^3/s", 0.0, 0.1, default=_NAN,
                                      doc="open loop: choke PI flow reference (back to automatic)")

    def changes(self, names) -> dict:
        """The fields among ``names`` that this entry sets (not absent, not NaN)."""
        values = {name: getattr(self, name) for name in names}
        return {k: v for k, v in values.items()
                if v is not None and not (isinstance(v, float) and math.isnan(v))}


MULTI_STAND_CONTROLLERS = ("nmpc", "baseline", "automated_mpd")   # those that plan a multi-stand trip
CLOSED_LOOP_FIELDS = ("bhp_ref_pa", "bhp_band_pa", "choke_dp_ref_pa", "choke_dp_band_pa",
                      "choke_dp_band_upper_pa",
                      "trip_speed_limit_mps", "controller_enabled")
OPEN_LOOP_FIELDS = ("block_speed_mps", "block_acceleration_mps2", "bpp_flow_m3s", "bpp_ramp_s",
                    "choke_opening", "choke_flow_ref_m3s")


@dataclass(frozen=True)
class Scenario:
    """One scenario file."""
    name: str = param()
    description: str = param()
    duration_s: float = param("s", 0.0, 1.0e5, lo_open=True)
    seed: int = param("1", 0, 2 ** 31 - 1)
    controller: str = param(choices=("nmpc", "automated_mpd", "baseline", "open_loop"))
    initial: Initial = param()
    schedule: tuple[SetpointChange, ...] = param()
    baseline_trip_speed_mps: float = param("m/s", 0.0, 5.0, lo_open=True, default=0.5)
    events: tuple[ScenarioEvent, ...] = param(default=(), doc="faults and formation changes "
                                                               "(drill_core.events)")
    operator: tuple[OperatorAction, ...] = param(
        default=(), doc="emergency stop, release, automation level at a time "
                        "(drill_core.operator_actions)")
    trip: TripProgramme | None = param(
        default=None, doc="a multi-stand trip (drill_core.tripping): the rig floor sets and "
                          "pulls the slips, makes the connections and ramps the mud pump; the "
                          "schedule's block targets are then the floor's, not the file's")

    @property
    def pulled_at_start_m(self) -> float:
        """The string's length off the configured one as the run starts [m]: a run-in
        trip's stands (drill_core.tripping.programme), else none."""
        return 0.0 if self.trip is None else self.trip.pulled_at_start_m

    def validate(self) -> None:
        times = [c.time_s for c in self.schedule]
        if times != sorted(times):
            raise ValueError("schedule entries must be in time order")
        if times[0] != 0.0:
            raise ValueError("the first schedule entry must be at time_s 0")
        open_loop = self.controller == "open_loop"
        unused = CLOSED_LOOP_FIELDS if open_loop else OPEN_LOOP_FIELDS
        for i, change in enumerate(self.schedule):
            named = list(change.changes(unused))
            if named:
                raise FieldError(f"schedule[{i}].{named[0]}", (
                    "not used with controller open_loop (no supervisor tracks it)" if open_loop
                    else f"only used with controller open_loop, not {self.controller}"))
        if open_loop:
            OpenLoopPlan(self.schedule, start_command(self.initial))
        if self.trip is not None:
            if self.controller not in MULTI_STAND_CONTROLLERS:
                raise FieldError("trip", f"a multi-stand trip runs under "
                                         f"{', '.join(MULTI_STAND_CONTROLLERS)}, not "
                                         f"{self.controller}")
            targets = [i for i, c in enumerate(self.schedule)
                       if math.isfinite(c.block_position_target_m)]
            if targets:
                raise FieldError(f"schedule[{targets[0]}].block_position_target_m",
                                 "a multi-stand trip's block targets are the rig floor's: "
                                 "leave it out")
        for key, timed in (("events", self.events), ("operator", self.operator)):
            for i, entry in enumerate(timed):
                if entry.time_s >= self.duration_s:
                    raise FieldError(f"{key}[{i}].time_s", f"value {entry.time_s} s must come "
                                                           f"before the end of the run, "
                                                           f"duration_s {self.duration_s} s")


@dataclass(frozen=True)
class ActiveSetpoints:
    """Setpoints in force (mirrors drill_msgs/Setpoints)."""
    bhp_ref_pa: float
    bhp_band_pa: float
    choke_dp_ref_pa: float
    choke_dp_band_pa: float
    block_position_target_m: float
    trip_speed_limit_mps: float
    controller_enabled: bool
    mud_pump_on: bool
    choke_dp_band_upper_pa: float = 0.0     # 0: choke_dp_band_pa (symmetric band)

    def following_rest(self, rest_choke_dp_pa: float, choke_dp_min_pa: float) -> ActiveSetpoints:
        """These setpoints with the choke-dp target moved down (not below
        ``choke_dp_min_pa``) to the steady dp that holds the BHP reference at rest, where that
        lies under it: a mud heavier or thicker than the model's needs less back-pressure,
        and the band moves with its target, keeping its room below it for the surge."""
        if not math.isfinite(rest_choke_dp_pa) or rest_choke_dp_pa >= self.choke_dp_ref_pa:
            return self
        return dataclasses.replace(self, choke_dp_ref_pa=max(rest_choke_dp_pa, choke_dp_min_pa))

    def choke_dp_limits(self, choke_dp_min_pa: float) -> tuple[float, float]:
        """The choke-dp band [Pa]: target - band (not below ``choke_dp_min_pa``) to target +
        upper width (the paper's Table 6 lets Cases 1-3 rise to the BHP band's bottom)."""
        upper = self.choke_dp_band_upper_pa if self.choke_dp_band_upper_pa > 0.0 \
            else self.choke_dp_band_pa
        low = max(self.choke_dp_ref_pa - self.choke_dp_band_pa, choke_dp_min_pa)
        return low, max(self.choke_dp_ref_pa + upper, low)


# The setpoint fields, from the one definition above (drill_msgs/Setpoints mirrors it).
SETPOINT_FIELDS = tuple(f.name for f in dataclasses.fields(ActiveSetpoints))
SETPOINT_BOOL_FIELDS = tuple(f.name for f in dataclasses.fields(ActiveSetpoints)
                             if f.type in ("bool", bool))
SETPOINT_NUMERIC_FIELDS = tuple(n for n in SETPOINT_FIELDS if n not in SETPOINT_BOOL_FIELDS)


def setpoints_at(scenario: Scenario, time_s: float, start: ActiveSetpoints) -> ActiveSetpoints:
    """Setpoints in force at ``time_s``: ``start`` with every due schedule entry applied."""
    current = start
    for change in scenario.schedule:
        if change.time_s > time_s + 1e-9:
            break
        current = dataclasses.replace(current, **change.changes(SETPOINT_FIELDS))
    return current


def scenario_kind(path: str | Path) -> str:
    """The ``kind`` of a scenario file: ``tripping`` (absent: this module's scenarios, the
    well-control graph) or ``drilling`` (drill_string.scenario: the drilling graph)."""
    data = load_yaml(path)
    kind = data.get("kind", "tripping") if isinstance(data, dict) else "tripping"
    if kind not in SCENARIO_KINDS:
        raise ConfigError(f"{path}: kind: value {kind!r} is not one of {', '.join(SCENARIO_KINDS)}")
    return kind


def load_scenario(path: str | Path) -> tuple[Scenario, dict]:
    """Read a tripping scenario file: the typed scenario and its config ``overrides`` mapping."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: <top>: expected a mapping")
    data = dict(data)
    kind = data.pop("kind", "tripping")
    if kind != "tripping":
        raise ConfigError(f"{path}: kind: value {kind!r}: not a tripping scenario (a drilling "
                          "scenario loads with drill_string.scenario)")
    overrides = data.pop("overrides", {}) or {}
    data.pop(TRUTH_KEY, None)       # the plant's alone: scenario_truth
    if not isinstance(overrides, dict):
        raise ConfigError(f"{path}: overrides: expected a mapping of config file stems")
    return build(Scenario, data, str(path)), overrides


def scenario_truth(path: str | Path, config_dir: str | Path) -> tuple[str, Mismatch] | None:
    """The scenario's ``truth:`` section (how its plant differs from the model:
    drill_core.mismatch) as (name, mismatch), None without one. Only the plant's side of
    the graph is given it (the launcher stages the scenario without it for the others)."""
    data = load_yaml(path)
    if not isinstance(data, dict) or data.get(TRUTH_KEY) is None:
        return None
    return resolve(data[TRUTH_KEY], config_dir, f"{path}: {TRUTH_KEY}")


def without_truth(path: str | Path) -> dict:
    """The scenario file's mapping less its ``truth:`` section (what the model's side reads)."""
    data = dict(load_yaml(path))
    data.pop(TRUTH_KEY, None)
    return data


def load_scenario_config(path: str | Path, config_dir: str | Path,
                         extra_overrides: dict | None = None) -> tuple[Scenario, RigConfig]:
    """The scenario and the rig configuration with the scenario's overrides applied (and
    ``extra_overrides`` over those: file stem -> mapping)."""
    scenario, overrides = load_scenario(path)
    if extra_overrides:
        overrides = merge(overrides, extra_overrides)
    return scenario, load_rig(config_dir, overrides)


def initial_setpoints(config: RigConfig, scenario: Scenario) -> ActiveSetpoints:
    """What is in force before the schedule's first entry (config defaults, initial point)."""
    n = config.nmpc
    ini = scenario.initial
    return ActiveSetpoints(bhp_ref_pa=math.nan, bhp_band_pa=n.bhp_band_pa,
                           choke_dp_ref_pa=ini.choke_dp_pa, choke_dp_band_pa=n.choke_dp_band_pa,
                           block_position_target_m=0.0, trip_speed_limit_mps=n.velocity_limit_mps,
                           controller_enabled=True, mud_pump_on=ini.circulation_m3s > 0.0)
