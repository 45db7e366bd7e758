"""Drilling mode: on-bottom drill-string dynamics after Tengesdal (2021), Paper IV. The
modules here import no ROS; ``drill_string.ros`` holds the drilling graph's nodes over them
(``scenario``: drilling scenarios and config/drilling.yaml, ``plant``: the string frame by
frame, ``drives``: the top drive and block feed; docs/drilling.md §6).

Entry points:

* ``simulate(DrillingConfig(...), duration_s, step_s) -> Trajectory`` and the stepping
  ``DrillStringSimulator(config).advance(duration_s, top_drive_rpm=..., block_speed_m_s=...)``;
* ``axial_stability(section, n, with_bha) -> StabilityResult`` (decoupled axial
  Walton-Marshall analysis: crossing frequencies, delays, delay margin, critical rpm);
* ``derive(section, n, with_bha) -> LumpedParameters`` (Tables 2-3 quantities);
* metrics ``stick_slip_severity``, ``stick_time_fraction``, ``longest_stick_s``,
  ``rate_of_penetration_m_s``.
"""
from .parameters import SECTIONS, LumpedParameters, WellSection, derive, section
from .simulate import (DrillingConfig, DrillStringSimulator, Trajectory, longest_stick_s,
                       paper_fig9_config, rate_of_penetration_m_s, simulate,
                       stick_slip_severity, stick_time_fraction)
from .stability import StabilityResult, axial_stability

__all__ = ["SECTIONS", "LumpedParameters", "WellSection", "derive", "section",
           "DrillingConfig", "DrillStringSimulator", "Trajectory", "simulate",
           "paper_fig9_config", "stick_slip_severity", "stick_time_fraction",
           "longest_stick_s", "rate_of_penetration_m_s", "StabilityResult", "axial_stability"]
