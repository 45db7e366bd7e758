"""Drilling scenarios (config/scenarios/drilling_*.yaml, ``kind: drilling``) and the
drilling rig's configuration (config/drilling.yaml), typed and validated like the rest of
the rig's configuration (drill_core.schema; SI units, except the top-drive speeds of a
scenario, which drillers and Paper IV give in rpm).

A scenario names the string (a Paper IV Table 1 section, its number of blocks, the BHA,
the mud viscosity), the operating point it starts from (a steady drilling state, with the
paper's initial perturbations), the driller's schedule of surface speeds and when its
start-up transient is over (``evaluate_from_s``). Its ``overrides`` change
config/drilling.yaml: sensor and actuator rates, the drives' lags, the sensor noise.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from drill_core.config import ConfigError, Lag
from drill_core.schema import FieldError, build, param
from drill_core.yaml_files import load_yaml, merge

from .parameters import SECTIONS, rpm_to_rad_s
from .simulate import DrillingConfig

_NAN = float("nan")
CONFIG_FILE = "drilling.yaml"


@dataclass(frozen=True)
class SensorNoise:
    """Standard deviation of each sensor (Gaussian, added to the frame's value); the names
    are the measurement fields (drill_msgs/SurfaceMeasurement, DownholeMeasurement)."""
    hook_load_n: float = param("N", 0.0)
    surface_torque_nm: float = param("N m", 0.0)
    top_drive_speed_rad_s: float = param("rad/s", 0.0)
    block_position_m: float = param("m", 0.0)
    wob_n: float = param("N", 0.0)
    tob_nm: float = param("N m", 0.0)
    bit_speed_rad_s: float = param("rad/s", 0.0)
    depth_of_cut_m: float = param("m", 0.0)
    bit_depth_m: float = param("m", 0.0)


def _whole_multiple(value: float, of: float) -> bool:
    ratio = value / of
    return abs(ratio - round(ratio)) < 1e-9 * max(1.0, ratio)


@dataclass(frozen=True)
class DrillingRig:
    """config/drilling.yaml: rates of the drilling graph, the drives, the sensors."""
    sensor_period_s: float = param("s", 0.0, 10.0, lo_open=True,
                                   doc="surface and downhole sensor frames: the lockstep's frame")
    actuator_step_s: float = param("s", 0.0, 1.0, lo_open=True,
                                   doc="spacing of the drives' output samples in a frame")
    command_period_s: float = param("s", 0.0, 60.0, lo_open=True,
                                    doc="the driller's command period")
    top_drive: Lag = param(doc="top-drive speed [rad/s]")
    block_feed: Lag = param(doc="block feed speed, positive down [m/s]")
    measurement_noise: SensorNoise = param()

    def validate(self) -> None:
        if not _whole_multiple(self.sensor_period_s, self.actuator_step_s):
            raise FieldError("sensor_period_s", f"value {self.sensor_period_s} s must be a whole "
                                                f"multiple of actuator_step_s {self.actuator_step_s} s")
        if not _whole_multiple(self.command_period_s, self.sensor_period_s):
            raise FieldError("command_period_s", f"value {self.command_period_s} s must be a whole "
                                                 f"multiple of sensor_period_s {self.sensor_period_s} s")
        if self.top_drive.minimum < 0.0:
            raise FieldError("top_drive.minimum", f"value {self.top_drive.minimum} rad/s: the top "
                                                  "drive does not turn backwards (at least 0)")

    @property
    def steps_per_frame(self) -> int:
        """Drive output samples per sensor frame."""
        return int(round(self.sensor_period_s / self.actuator_step_s))


@dataclass(frozen=True)
class DrillString:
    """The string (Paper IV Table 1 and section 2)."""
    section: str = param(choices=tuple(SECTIONS), doc="hole section of Paper IV Table 1")
    n_elements: int = param("1", 1, 40, doc="lumped blocks n")
    with_bha: bool = param(doc="the lowest block(s) are collars")
    mud_viscosity_pa_s: float | None = param("Pa s", 0.0, 10.0, lo_open=True, default=None,
                                             doc="default: the section's (Table 1)")


@dataclass(frozen=True)
class DrillingStart:
    """The steady drilling state the run starts from, and its perturbation (Paper IV
    section 5: Fig. 9 pushes the bit down, Figs. 5-6 start every block at half speed)."""
    top_drive_rpm: float = param("rpm", 0.0, 1000.0, lo_open=True)
    block_speed_m_s: float = param("m/s", 0.0, 1.0, lo_open=True, doc="positive down")
    bit_axial_speed_m_s: float = param("m/s", -10.0, 10.0, default=0.0,
                                       doc="added to the bit's steady axial speed at t = 0")
    rotation_fraction: float = param("1", 0.0, 2.0, default=1.0,
                                     doc="every block's speed at t = 0 over the top drive's")


@dataclass(frozen=True)
class DrillerChange:
    """Surface speeds the driller sets from ``time_s``; an absent field keeps its value."""
    time_s: float = param("s", 0.0, 1.0e6)
    top_drive_rpm: float = param("rpm", 0.0, 1000.0, default=_NAN)
    block_speed_m_s: float = param("m/s", -1.0, 1.0, default=_NAN, doc="positive down")


class SurfaceSpeeds(NamedTuple):
    """What the driller sets: the top drive's and the block's speed."""
    top_drive_rad_s: float
    block_speed_m_s: float          # positive down


@dataclass(frozen=True)
class DrillingScenario:
    """One drilling scenario file."""
    kind: str = param(choices=("drilling",))
    name: str = param()
    description: str = param()
    duration_s: float = param("s", 0.0, 1.0e5, lo_open=True)
    seed: int = param("1", 0, 2 ** 31 - 1, doc="sensor noise")
    string: DrillString = param()
    initial: DrillingStart = param()
    evaluate_from_s: float = param("s", 0.0, 1.0e5, default=0.0,
                                   doc="the run's summary metrics take the frames from here on "
                                       "(after the start-up transient)")
    schedule: tuple[DrillerChange, ...] = param(default=(), doc="the driller's speed changes")

    def validate(self) -> None:
        if self.evaluate_from_s >= self.duration_s:
            raise FieldError("evaluate_from_s", f"value {self.evaluate_from_s} s must come before "
                                                f"the end of the run, duration_s {self.duration_s} s")
        times = [c.time_s for c in self.schedule]
        if times != sorted(times):
            raise FieldError("schedule", "entries must be in time order")

    def drilling_config(self) -> DrillingConfig:
        """The simulator's configuration (drill_string.simulate)."""
        s, ini = self.string, self.initial
        return DrillingConfig(section=s.section, n_elements=s.n_elements, with_bha=s.with_bha,
                              top_drive_rpm=ini.top_drive_rpm,
                              block_speed_m_s=ini.block_speed_m_s,
                              mud_viscosity_pa_s=s.mud_viscosity_pa_s,
                              initial_bit_axial_speed_m_s=ini.bit_axial_speed_m_s,
                              initial_rotation_fraction=ini.rotation_fraction)

    @property
    def start_speeds(self) -> SurfaceSpeeds:
        """The speeds of the steady state the run starts from (the drives start there)."""
        return SurfaceSpeeds(rpm_to_rad_s(self.initial.top_drive_rpm),
                             self.initial.block_speed_m_s)

    def speeds_at(self, time_s: float) -> SurfaceSpeeds:
        """The driller's speeds in force at ``time_s``: the start's, changed by every due
        schedule entry."""
        rpm, block = self.initial.top_drive_rpm, self.initial.block_speed_m_s
        for change in self.schedule:
            if change.time_s > time_s + 1e-9:
                break
            rpm = rpm if math.isnan(change.top_drive_rpm) else change.top_drive_rpm
            block = block if math.isnan(change.block_speed_m_s) else change.block_speed_m_s
        return SurfaceSpeeds(rpm_to_rad_s(rpm), block)


def load_drilling_scenario(path: str | Path, config_dir: str | Path,
                           ) -> tuple[DrillingScenario, DrillingRig]:
    """The scenario and config/drilling.yaml with the scenario's ``overrides``
    (``{drilling: {...}}``) applied."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: <top>: expected a mapping")
    data = dict(data)
    overrides = data.pop("overrides", {}) or {}
    unknown = sorted(set(overrides) - {"drilling"}) if isinstance(overrides, dict) else ["?"]
    if unknown:
        raise ConfigError(f"{path}: overrides: a drilling scenario overrides only 'drilling' "
                          f"(config/{CONFIG_FILE}), not {', '.join(map(str, unknown))}")
    scenario = build(DrillingScenario, data, str(path))
    rig_path = Path(config_dir) / CONFIG_FILE
    rig = build(DrillingRig, merge(load_yaml(rig_path), overrides.get("drilling") or {}),
                str(rig_path))
    return scenario, rig
