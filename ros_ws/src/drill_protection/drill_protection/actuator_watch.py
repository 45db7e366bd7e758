"""Whether an actuator follows its reference, judged from its own frames.

A stuck actuator (a brake set, a seized valve) does not move its output while it is asked
to. A stuck drawworks, let go, catches up at its speed limit and jerks the string, which
swabs or surges; a stuck choke cannot make good the friction a tripped mud pump takes
with it (docs/faults.md, the fault matrix). The string's position or the pressures say
little here (a string stopped at speed rings on its stretch, the block controller's
integral lets the string rest a metre from its reference), so the watches read the
actuator's frames, the output its encoder reports: over a short window the reference moved
and the output did not (:class:`ActuatorWatch`), or, for a valve on its flow loop, the
loop's error stood and the valve did not move inside its range (:class:`StuckValveWatch`).
A pump has no frames the protection reads, but its flow is measured (the back-pressure
pump's stroke counter): :class:`PumpDeliveryWatch` compares it with what the pump's lag
makes of the commands sent. Plain Python; the protection acts on them.
"""
from __future__ import annotations

import math
from collections import deque

from drill_core.config import FollowingWatch, Lag, PumpWatch, ValveWatch


class FrameWindow:
    """One actuator's frames over the last ``window_s``: (stamp s, its reference or the
    value judged, the output's lowest and highest sample)."""

    def __init__(self, window_s: float):
        self.window_s = window_s
        self.frames: deque[tuple[float, float, float, float]] = deque()

    def add(self, stamp_s: float, value: float, output) -> None:
        """A frame stamped ``stamp_s`` [s]; non-finite output samples are left out (a frame
        without any is not judged)."""
        values = [float(v) for v in output if math.isfinite(v)]
        lo, hi = (min(values), max(values)) if values else (math.nan, math.nan)
        self.frames.append((stamp_s, float(value), lo, hi))
        while self.frames and self.frames[0][0] < stamp_s - self.window_s:
            self.frames.popleft()

    def has(self, stamp_s: float) -> bool:
        """Whether the frame stamped ``stamp_s`` has come."""
        return any(f[0] == stamp_s for f in self.frames)

    def before(self, now_s: float) -> list[tuple[float, float, float, float]]:
        """The frames stamped within the window before ``now_s`` (none at or after it)."""
        return [f for f in self.frames if now_s - self.window_s <= f[0] < now_s]

    def moving(self, now_s: float, travel: float) -> bool:
        """Whether the output moved at least ``travel`` over the window before ``now_s``."""
        seen = [f for f in self.before(now_s) if math.isfinite(f[2])]
        return bool(seen) and max(f[3] for f in seen) - min(f[2] for f in seen) >= travel


def _judged(frames) -> bool:
    """Enough frames, every value and output finite (a NaN value: nothing followed)."""
    return len(frames) >= 2 and all(math.isfinite(v) for f in frames for v in f[1:])


class ActuatorWatch:
    """``frame`` each frame of one actuator (its stamp, the reference it followed, its
    output samples); ``not_following(now_s)`` says whether, over the window before
    ``now_s``, the reference moved at least ``reference_travel`` (in the frames the
    output has had ``response_s`` to answer) while the output moved less than
    ``output_travel``; once it does, it keeps saying so for ``hold_s``."""

    def __init__(self, config: FollowingWatch):
        self.config = config
        self.window = FrameWindow(config.window_s)
        self.held_until_s = -math.inf

    def frame(self, stamp_s: float, reference: float, output) -> None:
        """One frame (reference NaN: none followed, e.g. the drawworks braked)."""
        self.window.add(stamp_s, reference, output)

    def has(self, stamp_s: float) -> bool:
        return self.window.has(stamp_s)

    def not_following(self, now_s: float) -> bool:
        c = self.config
        if now_s < self.held_until_s:
            return True
        seen = self.window.before(now_s)
        if not _judged(seen):
            return False
        references = [f[1] for f in seen if f[0] <= now_s - c.response_s]   # answered since
        reference_travel = max(references) - min(references) if references else 0.0
        if reference_travel >= c.reference_travel and not self.window.moving(now_s, c.output_travel):
            self.held_until_s = now_s + c.hold_s
            return True
        return False


class StuckValveWatch:
    """A valve on its flow loop that does not move: ``frame`` each frame with the loop's
    error (flow reference less the measured flow [m^3/s], NaN off the flow loop) and the
    valve's opening samples; ``not_following(now_s)`` says whether, over the window before
    ``now_s``, the error stood at ``flow_error_m3s`` or more (in the frames the valve has
    had ``response_s`` to answer) while the opening moved less than ``output_travel``
    more than ``range_margin`` inside ``valve``'s range (a valve at or slowing to a stop of
    its range cannot answer: not judged);
    ``moving(now_s)`` whether the opening moved that much, whatever it followed."""

    def __init__(self, config: ValveWatch, valve: Lag):
        self.config = config
        self.valve = valve
        self.window = FrameWindow(config.window_s)

    def frame(self, stamp_s: float, flow_error_m3s: float, output) -> None:
        self.window.add(stamp_s, flow_error_m3s, output)

    def has(self, stamp_s: float) -> bool:
        return self.window.has(stamp_s)

    def moving(self, now_s: float) -> bool:
        return self.window.moving(now_s, self.config.output_travel)

    def not_following(self, now_s: float) -> bool:
        c = self.config
        seen = self.window.before(now_s)
        if not _judged(seen):
            return False
        lo, hi = min(f[2] for f in seen), max(f[3] for f in seen)
        if lo <= self.valve.minimum + c.range_margin or hi >= self.valve.maximum - c.range_margin:
            return False
        errors = [abs(f[1]) for f in seen if f[0] <= now_s - c.response_s]
        return bool(errors) and min(errors) >= c.flow_error_m3s and hi - lo < c.output_travel


class PumpDeliveryWatch:
    """A pump that does not deliver: ``command`` each flow sent [m^3/s], ``observe`` each
    measured flow; the flow expected is the pump's first-order lag (``pump``'s time
    constant and range) driven by the commands. ``not_delivering`` says whether the
    measured flow has stood ``flow_error_m3s`` or more under it for ``window_s`` (a trip, or
    a pump stuck short of what it is asked for); a non-finite sample is not judged."""

    def __init__(self, config: PumpWatch, pump: Lag, initial_m3s: float):
        self.config = config
        self.pump = pump
        self.expected_m3s = float(initial_m3s)
        self.command_m3s = float(initial_m3s)
        self.last_s: float | None = None
        self.short_since_s: float | None = None   # when the flow fell short, None: it is not
        self.not_delivering = False

    def command(self, flow_m3s: float) -> None:
        self.command_m3s = min(max(float(flow_m3s), self.pump.minimum), self.pump.maximum)

    def observe(self, time_s: float, measured_m3s: float) -> None:
        if self.last_s is not None:
            gain = 1.0 - math.exp(-(time_s - self.last_s) / self.pump.time_constant_s)
            self.expected_m3s += (self.command_m3s - self.expected_m3s) * gain
        self.last_s = time_s
        if not math.isfinite(measured_m3s):
            return
        if self.expected_m3s - measured_m3s < self.config.flow_error_m3s:
            self.short_since_s = None
        elif self.short_since_s is None:
            self.short_since_s = time_s
        self.not_delivering = self.short_since_s is not None \
            and time_s - self.short_since_s >= self.config.window_s
