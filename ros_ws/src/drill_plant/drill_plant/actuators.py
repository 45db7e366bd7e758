"""Actuator models (DESIGN section 4): first-order lags with range and rate limits,
the drawworks' block-position controller, the choke's PI flow controller and a
command watchdog. Plain Python; the actuator node wires them to topics.

Each actuator advances one sensor frame at a time: given the command in force and
the measurement at t_k, it returns its output at t_k + i*dt for i = 0..N-1, the
samples the plant holds over the frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drill_core import hydraulics as hy
from drill_core.block_control import block_command, integral_rate
from drill_core.config import Actuators, Lag


def clamp(value: float, lo: float, hi: float) -> float:
    return min(max(value, lo), hi)


class FirstOrderLag:
    """y' = (c - y)/T with |y'| <= rate limit and c clamped to [min, max]."""

    def __init__(self, lag: Lag, initial: float):
        self.lag = lag
        self.value = clamp(initial, lag.minimum, lag.maximum)

    def limit(self, command: float) -> float:
        return clamp(command, self.lag.minimum, self.lag.maximum)

    def advance(self, command: float, step_s: float, steps: int) -> np.ndarray:
        """Outputs at the start of each of ``steps`` steps; the state moves to the frame end."""
        target = self.limit(command)
        max_change = self.lag.rate_limit_per_s * step_s
        keep = np.exp(-step_s / self.lag.time_constant_s)
        out = np.empty(steps)
        for i in range(steps):
            out[i] = self.value
            change = (target - self.value) * (1.0 - keep)
            self.value = clamp(self.value + clamp(change, -max_change, max_change),
                               self.lag.minimum, self.lag.maximum)
        return out


class Watchdog:
    """Trips when no command arrived for ``timeout_s``."""

    def __init__(self, timeout_s: float):
        self.timeout_ns = int(timeout_s * 1e9)
        self.last_command_ns: int | None = None

    def feed(self, now_ns: int) -> None:
        self.last_command_ns = now_ns

    def tripped(self, now_ns: int) -> bool:
        return self.last_command_ns is None or now_ns - self.last_command_ns > self.timeout_ns


@dataclass
class FrameOutput:
    """What an actuator reports for one frame."""
    command: float          # limited command driving the lag [SI]
    reference: float        # upstream reference [SI]
    output: np.ndarray      # samples over the frame [SI]


class Drawworks:
    """Block-position controller + drawworks lag; the reference is u_r [m]."""

    def __init__(self, config: Actuators, static_stretch_m: float, initial_block_m: float):
        self.config = config
        self.static_stretch_m = static_stretch_m
        self.lag = FirstOrderLag(config.drawworks, initial_block_m)
        self.integral_m_s = 0.0

    def safe_reference(self, measured_position_m: float) -> float:
        """Hold the string where it is."""
        return measured_position_m

    def frame(self, reference_m: float, measured_position_m: float, step_s: float,
              steps: int) -> FrameOutput:
        command = block_command(reference_m, measured_position_m, self.integral_m_s,
                                self.static_stretch_m, self.config.block_kp,
                                self.config.block_ki_per_s)
        limited = self.lag.limit(command)
        if limited == command:     # anti-windup: integrate only while unsaturated
            self.integral_m_s += integral_rate(reference_m, measured_position_m) * step_s * steps
        return FrameOutput(limited, reference_m, self.lag.advance(limited, step_s, steps))


class Choke:
    """PI flow controller (velocity form) + choke-valve lag; the reference is a choke flow [m^3/s].

    The controlled flow is inferred from the valve law with the measured differential
    pressure and the current opening (the choke flow itself is not measured). Like a choke
    panel, it has a manual mode that drives the valve to a given opening, bypassing the PI
    (the paper's estimation study, sec. 4.3, holds the choke at 50 %); back in automatic
    the velocity-form PI continues from the opening it was left at (bumpless).
    """

    def __init__(self, config: Actuators, wm: hy.WellModel, initial_opening: float):
        self.config = config
        self.wm = wm
        self.lag = FirstOrderLag(config.choke, initial_opening)
        self.opening_command = self.lag.value
        self.previous_error: float | None = None

    def frame(self, flow_ref_m3s: float, measured_dp_pa: float, step_s: float,
              steps: int, manual_opening: float | None = None) -> FrameOutput:
        """One frame; ``manual_opening`` [1] (not None) is manual mode and the frame's
        reference is then NaN (no flow reference)."""
        if manual_opening is not None:
            self.opening_command = self.lag.limit(manual_opening)
            self.previous_error = None
            return FrameOutput(self.opening_command, math.nan,
                               self.lag.advance(self.opening_command, step_s, steps))
        c = self.config
        flow = float(hy.choke_flow(self.wm, self.lag.value, measured_dp_pa))
        error = (flow_ref_m3s - flow) / c.choke_flow_scale_m3s
        previous = error if self.previous_error is None else self.previous_error
        dt = step_s * steps
        self.opening_command = self.lag.limit(
            self.opening_command + c.choke_kp * ((error - previous) + dt / c.choke_ti_s * error))
        self.previous_error = error
        return FrameOutput(self.opening_command, flow_ref_m3s,
                           self.lag.advance(self.opening_command, step_s, steps))


class Pump:
    """Back-pressure pump (flow) or mud pump (stand-pipe pressure): a lag on the command."""

    def __init__(self, lag: Lag, initial: float):
        self.lag = FirstOrderLag(lag, initial)

    def frame(self, command: float, step_s: float, steps: int) -> FrameOutput:
        limited = self.lag.limit(command)
        return FrameOutput(limited, command, self.lag.advance(limited, step_s, steps))
