"""Actuator models (docs/design.md §4): first-order lags with range and rate limits,
the drawworks' block-position controller, the choke's PI flow controller (on the
return-flow meter) and pressure controller, and a command watchdog. Plain Python; the
actuator node wires them to topics.

Each actuator advances one sensor frame at a time: given the command in force and
the measurement at t_k, it returns its output at t_k + i*dt for i = 0..N-1, the
samples the plant holds over the frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drill_core import hydraulics as hy
from drill_core.block_control import block_command, integral_for_command, integral_rate
from drill_core.channel_watch import ChannelWatch
from drill_core.config import Actuators, Lag


def clamp(value: float, lo: float, hi: float) -> float:
    return min(max(value, lo), hi)


class FirstOrderLag:
    """y' = (c - y)/T with |y'| <= rate limit and c clamped to [min, max]."""

    def __init__(self, lag: Lag, initial: float):
        self.lag = lag
        self.value = clamp(initial, lag.minimum, lag.maximum)
        self.rate_per_s = 0.0       # the output's rate over the last step [unit/s]

    def limit(self, command: float) -> float:
        return clamp(command, self.lag.minimum, self.lag.maximum)

    def advance(self, command: float, step_s: float, steps: int) -> np.ndarray:
        """Outputs at the start of each of ``steps`` steps; the state moves to the frame end."""
        lo, hi = self.lag.minimum, self.lag.maximum
        target = self.limit(command)
        max_change = self.lag.rate_limit_per_s * step_s
        gain = 1.0 - float(np.exp(-step_s / self.lag.time_constant_s))
        value, out = self.value, []
        for _ in range(steps):
            out.append(value)
            value = clamp(value + clamp((target - value) * gain, -max_change, max_change),
                          lo, hi)
        self._moved_to(value, out[-1], step_s)
        return np.array(out)

    def decelerate(self, deceleration_per_s2: float, step_s: float, steps: int) -> np.ndarray:
        """Outputs at the start of each step while the output's rate falls to zero at
        ``deceleration_per_s2`` and then stays there (a brake); the state moves to the frame end."""
        value, rate, out = self.value, self.rate_per_s, []
        for _ in range(steps):
            out.append(value)
            rate = math.copysign(max(abs(rate) - deceleration_per_s2 * step_s, 0.0), rate)
            value = clamp(value + rate * step_s, self.lag.minimum, self.lag.maximum)
        self._moved_to(value, out[-1], step_s)
        return np.array(out)

    def hold(self, steps: int) -> np.ndarray:
        """The output frozen where it is for ``steps`` steps (a stuck actuator)."""
        self.rate_per_s = 0.0
        return np.full(steps, self.value)

    def _moved_to(self, value: float, before: float, step_s: float) -> None:
        self.rate_per_s = (value - before) / step_s
        self.value = value


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
    """Block-position controller + drawworks lag; the reference is u_r [m]. The emergency
    brake (``brake``) and the block's own moves with the string in the slips
    (``drive_block``) bypass the controller: braked, the block decelerates at the brake's
    limit to rest and is held there; the first frame after either takes the controller back
    from where the block is without a jump (its integral set so that it commands there)."""

    def __init__(self, config: Actuators, static_stretch_m: float, initial_block_m: float):
        self.config = config
        self.static_stretch_m = static_stretch_m
        self.lag = FirstOrderLag(config.drawworks, initial_block_m)
        self.integral_m_s = 0.0
        self.command_m = self.lag.value
        self.off_loop = False

    def safe_reference(self, measured_position_m: float) -> float:
        """Hold the string where it is."""
        return measured_position_m

    def brake(self, step_s: float, steps: int) -> FrameOutput:
        """One frame with the brake set; the frame's reference is NaN (none is followed)."""
        self.off_loop = True
        out = self.lag.decelerate(self.config.brake_deceleration_mps2, step_s, steps)
        self.command_m = self.lag.value
        return FrameOutput(self.command_m, math.nan, out)

    def drive_block(self, target_m: float, step_s: float, steps: int) -> FrameOutput:
        """One frame with the block on its own encoder (the string in the slips, the
        elevator off or slack: the string's position says nothing of the block): the lag
        driven to ``target_m`` [m]; the frame's reference is NaN (no block reference is
        followed); the next frame on the string's loop takes over from where the block is
        without a jump, as after the brake."""
        self.off_loop = True
        self.command_m = self.lag.limit(target_m)
        return FrameOutput(self.command_m, math.nan,
                           self.lag.advance(self.command_m, step_s, steps))

    def frame(self, reference_m: float, measured_position_m: float, step_s: float,
              steps: int) -> FrameOutput:
        """One frame; a non-finite reference or position holds the last command (the
        controller's integral untouched, so one bad sample does not poison it)."""
        if math.isfinite(reference_m) and math.isfinite(measured_position_m):
            c = self.config
            if self.off_loop and c.block_ki_per_s > 0.0:   # released: bumpless from the held block
                self.integral_m_s = integral_for_command(self.lag.value, reference_m,
                                                         measured_position_m, self.static_stretch_m,
                                                         c.block_kp, c.block_ki_per_s)
            self.off_loop = False
            command = block_command(reference_m, measured_position_m, self.integral_m_s,
                                    self.static_stretch_m, self.config.block_kp,
                                    self.config.block_ki_per_s)
            self.command_m = self.lag.limit(command)
            if self.command_m == command:     # anti-windup: integrate only while unsaturated
                self.integral_m_s += integral_rate(reference_m, measured_position_m) * step_s * steps
        return FrameOutput(self.command_m, reference_m, self.lag.advance(self.command_m, step_s, steps))


class Choke:
    """Choke panel: PI flow controller (velocity form), PI pressure controller, or manual;
    then the choke-valve lag.

    Flow mode (the paper's): the reference is a choke flow [m^3/s]; the controlled flow is
    the Coriolis meter's return flow (the flow through the choke line). A bad sample of it
    (NaN, inf, or frozen: the same value ``choke_flow_frozen_after_samples`` frames running)
    falls back on the valve law with the measured differential pressure and the current
    opening, counted in ``valve_law_frames``: the valve law takes the clean valve
    coefficient, so a plugging choke passes less than it says (docs/faults.md).

    Pressure mode (an MPD choke controller's surface back-pressure loop): at every sensor
    frame a PI on the measured choke dp against a set-point that ramps from the command's
    value at its rate, plus the opening the valve law gives for a feedforward flow at that
    set-point. BHP mode (the emergency stop's hold): the same loop on the measured BHP, its
    set-point the BHP to hold, as a cascade: an outer PI on the BHP sets the pressure loop's
    choke-dp set-point (while the BHP sample is bad the set-point stands). The choke-dp and
    BHP gauges are screened every frame (``gauges``): a frozen one (the same sample
    ``choke_gauges_frozen_after_samples`` frames running) reads as a NaN, so the loops hold
    instead of integrating against a gauge that no longer moves. Manual mode
    drives the valve to a given opening (the paper's estimation study, sec. 4.3, holds the
    choke at 50 %). Every switch is bumpless: each mode continues from the opening the
    valve was left at.
    """

    def __init__(self, config: Actuators, wm: hy.WellModel, initial_opening: float):
        self.config = config
        self.wm = wm
        self.lag = FirstOrderLag(config.choke, initial_opening)
        self.opening_command = self.lag.value
        self.previous_error: float | None = None
        self.pressure_integral: float | None = None     # pressure and BHP modes' integral [1]
        self.pressure_mode = ""                         # "dp" or "bhp" while one runs, else ""
        self.bhp_dp_integral_pa = math.nan              # BHP mode: the outer loop's integral
        self.bhp_dp_setpoint_pa = math.nan              # and the choke-dp set-point it sets [Pa]
        self.flow_watch = ChannelWatch(("return_flow_m3s",), config.choke_flow_frozen_after_samples)
        self.gauge_watch = ChannelWatch(("choke_dp_pa", "bhp_pa"),
                                        config.choke_gauges_frozen_after_samples)
        self.valve_law_frames = 0     # flow-mode frames on the valve law (bad return-flow sample)

    def gauges(self, choke_dp_pa: float, bhp_pa: float) -> tuple[float, float]:
        """The frame's choke-dp and BHP samples [Pa], each NaN when frozen (call once per
        frame)."""
        screened, _ = self.gauge_watch.screen(0.0, [choke_dp_pa, bhp_pa])
        return float(screened[0]), float(screened[1])

    def measured_flow(self, return_flow_m3s: float, measured_dp_pa: float) -> float:
        """The flow loop's measured choke flow [m^3/s]: the return-flow sample, or the valve
        law at the current opening and ``measured_dp_pa`` when the sample is bad."""
        screened, _ = self.flow_watch.screen(0.0, [return_flow_m3s])    # (no staleness kept)
        if math.isfinite(screened[0]):
            return float(screened[0])
        self.valve_law_frames += 1
        return float(hy.choke_flow(self.wm, self.lag.value, measured_dp_pa))

    def frame(self, flow_ref_m3s: float, measured_dp_pa: float, step_s: float,
              steps: int, manual_opening: float | None = None,
              return_flow_m3s: float = math.nan) -> FrameOutput:
        """One frame; ``return_flow_m3s`` is the return-flow sample the flow loop controls
        (the valve law when it is bad); ``manual_opening`` [1] (not None) is manual mode
        and the frame's reference is then NaN (no flow reference)."""
        self._enter("")
        if manual_opening is not None:
            self.opening_command = self.lag.limit(manual_opening)
            self.previous_error = None
            return FrameOutput(self.opening_command, math.nan,
                               self.lag.advance(self.opening_command, step_s, steps))
        c = self.config
        flow = self.measured_flow(return_flow_m3s, measured_dp_pa) \
            if math.isfinite(flow_ref_m3s) else math.nan
        if not math.isfinite(flow):
            # a bad reference, or no usable flow sample (and no dp for the valve law): the
            # opening is held, the PI's memory stays clean
            return FrameOutput(self.opening_command, flow_ref_m3s,
                               self.lag.advance(self.opening_command, step_s, steps))
        error = (flow_ref_m3s - flow) / c.choke_flow_scale_m3s
        previous = error if self.previous_error is None else self.previous_error
        dt = step_s * steps
        self.opening_command = self.lag.limit(
            self.opening_command + c.choke_kp * ((error - previous) + dt / c.choke_ti_s * error))
        self.previous_error = error
        return FrameOutput(self.opening_command, flow_ref_m3s,
                           self.lag.advance(self.opening_command, step_s, steps))

    def pressure_frame(self, dp_ref_pa: float, dp_ref_rate_pa_s: float, since_command_s: float,
                       flow_feedforward_m3s: float, measured_dp_pa: float, step_s: float,
                       steps: int) -> FrameOutput:
        """One frame in pressure mode; the frame's reference is the choke-dp set-point [Pa]
        in force, dp_ref + rate * (time since the command). A non-finite input (a bad
        sample or set-point) holds the opening and leaves the controller's state as it was."""
        self._enter("dp")
        return self._pressure_loop(dp_ref_pa, dp_ref_rate_pa_s, since_command_s,
                                   flow_feedforward_m3s, measured_dp_pa, step_s, steps)

    def bhp_frame(self, bhp_ref_pa: float, measured_bhp_pa: float, dp_start_pa: float,
                  flow_feedforward_m3s: float, measured_dp_pa: float, step_s: float,
                  steps: int) -> FrameOutput:
        """One frame in BHP mode, a cascade: an outer PI on the measured BHP against
        ``bhp_ref_pa`` sets the choke-dp set-point of the pressure loop (the BHP answers the
        choke a pressure wave's travel later than the choke dp does). The set-point starts
        from ``dp_start_pa`` (a feedforward of what the stop changes; NaN: the measured dp);
        the outer integral stands while the valve is at an end of its range or the
        BHP sample is bad (the pressure loop then holds the last set-point). Entering the
        mode the loop takes the valve where it is, not where its last command was taking
        it (a valve closing when the stop comes stops there). The frame's reference is the
        set-point [Pa]."""
        c = self.config
        if self.pressure_mode != "bhp":
            start = dp_start_pa if math.isfinite(dp_start_pa) else measured_dp_pa
            self.bhp_dp_integral_pa = self.bhp_dp_setpoint_pa = start
            self.opening_command = self.lag.value       # the valve stopped where it is
        self._enter("bhp")
        error = bhp_ref_pa - measured_bhp_pa                  # BHP low: more back-pressure
        if math.isfinite(error) and math.isfinite(self.bhp_dp_integral_pa):
            if self.lag.lag.minimum < self.opening_command < self.lag.lag.maximum:
                self.bhp_dp_integral_pa += c.choke_bhp_kp * step_s * steps / c.choke_bhp_ti_s * error
            self.bhp_dp_setpoint_pa = self.bhp_dp_integral_pa + c.choke_bhp_kp * error
        return self._pressure_loop(self.bhp_dp_setpoint_pa, 0.0, 0.0, flow_feedforward_m3s,
                                   measured_dp_pa, step_s, steps)

    def _enter(self, mode: str) -> None:
        """Switching mode: the next pressure loop starts bumpless from the opening in force."""
        if mode != self.pressure_mode:
            self.pressure_integral = None
            self.pressure_mode = mode

    def _pressure_loop(self, dp_ref_pa: float, dp_ref_rate_pa_s: float, since_command_s: float,
                       flow_feedforward_m3s: float, measured_dp_pa: float, step_s: float,
                       steps: int) -> FrameOutput:
        c = self.config
        setpoint = max(dp_ref_pa + dp_ref_rate_pa_s * since_command_s, 0.0)
        if not all(math.isfinite(v) for v in (setpoint, flow_feedforward_m3s, measured_dp_pa)):
            return FrameOutput(self.opening_command, setpoint,
                               self.lag.advance(self.opening_command, step_s, steps))
        error = (measured_dp_pa - setpoint) / c.choke_pressure_scale_pa   # too high: open
        feedforward = hy.choke_opening_for_flow(self.wm, max(flow_feedforward_m3s, 0.0),
                                                max(setpoint, self.wm.choke_regularisation_pa))
        proportional = c.choke_pressure_kp * error
        if self.pressure_integral is None:      # bumpless entry from the opening in force
            self.pressure_integral = self.opening_command - feedforward - proportional
        trial = self.pressure_integral + c.choke_pressure_kp * step_s * steps \
            / c.choke_pressure_ti_s * error
        command = feedforward + proportional + trial
        if self.lag.limit(command) == command:   # anti-windup: integrate only while unsaturated
            self.pressure_integral = trial
        self.opening_command = self.lag.limit(feedforward + proportional + self.pressure_integral)
        self.previous_error = None
        return FrameOutput(self.opening_command, setpoint,
                           self.lag.advance(self.opening_command, step_s, steps))


class Pump:
    """Back-pressure pump (flow) or mud pump (stand-pipe pressure): a lag on the command."""

    def __init__(self, lag: Lag, initial: float):
        self.lag = FirstOrderLag(lag, initial)

    def frame(self, command: float, step_s: float, steps: int) -> FrameOutput:
        limited = self.lag.limit(command)
        return FrameOutput(limited, command, self.lag.advance(limited, step_s, steps))
