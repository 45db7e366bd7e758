"""The drilling plant, frame by frame: the drill string of a drilling scenario advanced one
sensor frame at a time on the top drive's and the block feed's output samples, the
frame's sensor values (surface, and downhole over wired pipe) and its every step (the
truth, for evaluation). Plain Python; ``drill_string.ros.plant_node`` moves it to topics.

Each drive sample is held over its actuator step; the string is stepped at the largest
step not above the default 2.5e-3 t* that divides the actuator step, so a frame is a
whole number of steps and the frames of a run give, step for step, the samples of one
``simulate()`` at the same step. Loads, speeds and the depth of cut are measured as means
over the frame (the stop of a sticking bit puts a one-step impulse on WOB and TOB that a
point sample could catch), positions at its end.
"""
from __future__ import annotations

import math

import numpy as np

from .scenario import DrillingRig, DrillingScenario
from .simulate import DEFAULT_SCALED_STEP, DrillStringSimulator, Trajectory

# measurement field (= its Trajectory field) -> what a frame gives: its mean or its end value
SURFACE_CHANNELS = {"hook_load_n": "mean", "surface_torque_nm": "mean",
                    "top_drive_speed_rad_s": "mean", "block_position_m": "end"}
DOWNHOLE_CHANNELS = {"wob_n": "mean", "tob_nm": "mean", "bit_speed_rad_s": "mean",
                     "depth_of_cut_m": "mean", "bit_depth_m": "end"}


def plant_step_s(actuator_step_s: float, t_star_s: float) -> float:
    """The largest step not above DEFAULT_SCALED_STEP t* that divides ``actuator_step_s``."""
    return actuator_step_s / math.ceil(actuator_step_s / (DEFAULT_SCALED_STEP * t_star_s) - 1e-9)


class DrillingPlant:
    """One drilling scenario's string; ``advance`` one frame, then read its sensors and
    steps. ``seed`` draws the sensor noise."""

    def __init__(self, scenario: DrillingScenario, rig: DrillingRig, seed: int):
        self.scenario, self.rig = scenario, rig
        config = scenario.drilling_config()
        self.sim = DrillStringSimulator(
            config, plant_step_s(rig.actuator_step_s, config.parameters().t_star_s))
        start = scenario.start_speeds
        self.held = {"top_drive": start.top_drive_rad_s, "block_feed": start.block_speed_m_s}
        self.steps: Trajectory | None = None    # the last frame's steps (None before the first)
        self.frames = 0
        self._rng = np.random.default_rng(seed)

    def advance(self, top_drive_rad_s, block_speed_m_s) -> list[str]:
        """Integrate one frame on the drives' samples. A drive whose samples are not
        ``steps_per_frame`` finite values is held at its last input; the names of those
        drives are returned."""
        given = {"top_drive": top_drive_rad_s, "block_feed": block_speed_m_s}
        n = self.rig.steps_per_frame
        bad, inputs = [], {}
        for drive in given:
            samples = np.asarray(given[drive], dtype=float)
            if samples.shape != (n,) or not np.all(np.isfinite(samples)):
                bad.append(drive)
                samples = np.full(n, self.held[drive])
            inputs[drive] = samples
            self.held[drive] = float(samples[-1])
        self.steps = Trajectory.concatenate([
            self.sim.advance(self.rig.actuator_step_s, top_drive_rad_s=float(w),
                             block_speed_m_s=float(v))
            for w, v in zip(inputs["top_drive"], inputs["block_feed"])])
        self.frames += 1
        return bad

    @property
    def evaluated(self) -> bool:
        """Whether the last frame started at or after the scenario's ``evaluate_from_s``."""
        start_s = (self.frames - 1) * self.rig.sensor_period_s
        return self.frames > 0 and start_s >= self.scenario.evaluate_from_s - 1e-9

    def sensors(self, channels: dict[str, str]) -> dict[str, float]:
        """The frame's value of each channel (SURFACE_CHANNELS, DOWNHOLE_CHANNELS) with its
        sensor noise; before the first frame, the initial state's."""
        frame = self.steps if self.steps is not None else self.sim.sample()
        out = {}
        for name, how in channels.items():
            values = getattr(frame, name)
            value = float(np.mean(values)) if how == "mean" else float(values[-1])
            out[name] = value + float(self._rng.normal(0.0, getattr(self.rig.measurement_noise,
                                                                    name)))
        return out
