"""Scenario files (config/scenarios/*.yaml): initial operating point, controller,
configuration overrides and a timed setpoint schedule (DESIGN section 8).

A schedule entry changes only the fields it names; the rest carry over. Times are
simulated seconds from the start of the run.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

from drill_core.config import ConfigError, RigConfig, load_rig, load_yaml
from drill_core.schema import build, param

_NAN = float("nan")


@dataclass(frozen=True)
class Initial:
    """Steady operating point the run starts from."""
    circulation_m3s: float = param("m^3/s", 0.0, 0.1, doc="0 = mud pump off")
    choke_dp_pa: float = param("Pa", 0.0, 1.0e7)
    bpp_flow_m3s: float = param("m^3/s", 0.0, 0.1)


@dataclass(frozen=True)
class SetpointChange:
    """Setpoints changed at ``time_s``; NaN/absent fields keep their previous value."""
    time_s: float = param("s", 0.0, 1.0e6)
    bhp_ref_pa: float = param("Pa", 0.0, 5.0e8, default=_NAN)
    bhp_band_pa: float = param("Pa", 0.0, 1.0e7, lo_open=True, default=_NAN)
    choke_dp_ref_pa: float = param("Pa", 0.0, 1.0e8, default=_NAN)
    choke_dp_band_pa: float = param("Pa", 0.0, 1.0e7, lo_open=True, default=_NAN)
    block_position_target_m: float = param("m", -100.0, 100.0, default=_NAN)
    trip_speed_limit_mps: float = param("m/s", 0.0, 5.0, lo_open=True, default=_NAN)
    controller_enabled: bool = param(default=True)
    mud_pump_on: bool = param(default=True)


@dataclass(frozen=True)
class Scenario:
    """One scenario file."""
    name: str = param()
    description: str = param()
    duration_s: float = param("s", 0.0, 1.0e5, lo_open=True)
    seed: int = param("1", 0, 2 ** 31 - 1)
    controller: str = param(choices=("nmpc", "baseline", "open_loop"))
    initial: Initial = param()
    schedule: tuple[SetpointChange, ...] = param()
    baseline_trip_speed_mps: float = param("m/s", 0.0, 5.0, lo_open=True, default=0.5)

    def validate(self) -> None:
        times = [c.time_s for c in self.schedule]
        if times != sorted(times):
            raise ValueError("schedule entries must be in time order")
        if times[0] != 0.0:
            raise ValueError("the first schedule entry must be at time_s 0")


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


def setpoints_at(scenario: Scenario, time_s: float, start: ActiveSetpoints) -> ActiveSetpoints:
    """Setpoints in force at ``time_s``: ``start`` with every due schedule entry applied."""
    current = start
    for change in scenario.schedule:
        if change.time_s > time_s + 1e-9:
            break
        updates = {f.name: getattr(change, f.name) for f in dataclasses.fields(ActiveSetpoints)}
        updates = {k: v for k, v in updates.items()
                   if not (isinstance(v, float) and math.isnan(v))}
        current = dataclasses.replace(current, **updates)
    return current


def load_scenario(path: str | Path) -> tuple[Scenario, dict]:
    """Read a scenario file: the typed scenario and its config ``overrides`` mapping."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: <top>: expected a mapping")
    data = dict(data)
    overrides = data.pop("overrides", {}) or {}
    if not isinstance(overrides, dict):
        raise ConfigError(f"{path}: overrides: expected a mapping of config file stems")
    return build(Scenario, data, str(path)), overrides


def load_scenario_config(path: str | Path, config_dir: str | Path) -> tuple[Scenario, RigConfig]:
    """The scenario and the rig configuration with the scenario's overrides applied."""
    scenario, overrides = load_scenario(path)
    return scenario, load_rig(config_dir, overrides)
