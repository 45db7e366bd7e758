"""Kick and loss detection from the surface flows (plain Python; docs/design.md §10).

The well's mud balance (docs/model.md, formation and pit) says what leaves the well
beyond what is pumped in is the formation's, once two known terms are taken out:

    influx - losses = ∫ (q_return - q_string - q_bpp) dt + A_net Δx_s
                      + C_top Δp_choke + C_bottom Δp_bottom

(A_net Δx_s: the volume the moving string vacates; the C terms: the mud that pressure
changes compress, the annulus pressure taken linear in depth between the choke and the
bottom-hole gauge, the string's with the bottom one, each pressure the median of its last
second: robust to its noise and to a single bad sample). That *excess volume*, averaged
into an *excess flow* over a window, less the baseline learnt while the well is quiet
(drill_protection.flow_baseline: the compliances' errors, when ``baseline_time_constant_s``
is set), raises a kick alarm when it stays above the
threshold for the confirmation time, a losses alarm when it stays below minus the
threshold, and clears once it has stayed within half the threshold as long. The baseline
only takes an excess away: the balance without it must read beyond the threshold too. A sample with
a non-finite flow is rejected; one without a block position or a pressure (its median
empty) keeps the flows in the balance and is not judged: the position and compliance
terms catch up with the flows once the gauge is back. A pressure gauge out for
``pressure_gap_judged_after_s`` is judged again with its last reading held. Bad samples
are counted; a sample without a string-flow reading (mud pump off) adds nothing to the
balance, so detection pauses.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from drill_core.config import KickDetection, RigConfig
from drill_core.recent_samples import RecentSamples
from drill_core.surface_flows import delta_flow_m3s
from drill_core.well import WellGeometry
from drill_protection.flow_baseline import FlowBaseline
from drill_protection.slope import LeastSquaresSlope


# The windowed excess flow's scatter about the baseline the fit assumes, as a share of the
# alarm threshold (meter noise over a window plus what the balance leaves out).
BASELINE_NOISE_SHARE = 0.25


@dataclass(frozen=True)
class FlowSample:
    """One sensor sample of what the detector reads (SI)."""
    time_s: float
    return_flow_m3s: float      # Coriolis on the choke line
    string_flow_m3s: float      # into the string (NaN: not measured, pump off)
    bpp_flow_m3s: float         # back-pressure pump, into the choke line
    string_position_m: float
    choke_dp_pa: float
    bhp_pa: float
    pit_volume_m3: float = math.nan   # active pit (NaN: no reading)


@dataclass(frozen=True)
class Detection:
    """The detector's reading after a sample."""
    excess_flow_m3s: float      # averaged over the window (NaN until it has one)
    pit_gain_flow_m3s: float    # the pit's reading of it over pit_window_s (NaN until then)
    excess_volume_m3: float     # influx - losses since the balance started, as it reads them
    alarm: str                  # "", "kick" or "losses"
    raised: bool                # the alarm was raised on this sample
    volume_at_alarm_m3: float   # excess volume gained since the flow first crossed the threshold


class KickDetector:
    """Flow-balance kick and loss detector for one run."""

    def __init__(self, config: KickDetection, net_displacement_area_m2: float,
                 compliance_top_m3_pa: float, compliance_bottom_m3_pa: float):
        self.config = config
        self.area_m2 = net_displacement_area_m2
        self.compliance_m3_pa = (compliance_top_m3_pa, compliance_bottom_m3_pa)
        self._pressures = (RecentSamples(config.pressure_average_s),    # choke dp, BHP [Pa]
                           RecentSamples(config.pressure_average_s))
        self.rejected = 0
        self.rejected_pit = 0                   # pit samples left out (NaN, inf)
        self.alarm = ""
        self._integral_m3 = 0.0
        self._first: FlowSample | None = None
        self._first_pressures: list[float] = []  # the pressures' medians when the balance began
        self._held_pressures: list[float] = []   # the last medians (choke dp, BHP) [Pa]
        self._last_time_s: float | None = None
        self._pressure_gap_since_s: float | None = None  # the first sample without a pressure
        self._history: deque = deque()          # (time s, excess volume m^3, choke dp Pa,
                                                # BHP Pa: the pressures' medians)
        self.baseline = FlowBaseline(config.baseline_time_constant_s,
                                     BASELINE_NOISE_SHARE * config.flow_threshold_m3s,
                                     config.window_s) \
            if config.baseline_time_constant_s > 0.0 else None
        self._pit = LeastSquaresSlope()         # (time s from its start, the pit's excess
                                                # volume m^3) over its window
        self._pit_start: tuple[float, float, float] | None = None  # (time s, pit m^3, known m^3)
        self._since: dict[str, float | None] = {"kick": None, "losses": None, "clear": None}
        self._onset_volume: dict[str, float] = {}
        self._raised_volume = math.nan

    def update(self, s: FlowSample) -> Detection:
        """Take one sample; the reading after it."""
        needed = (s.time_s, s.return_flow_m3s, s.bpp_flow_m3s)
        if not all(math.isfinite(v) for v in needed):
            self.rejected += 1
            return self._reading(False)
        pressures_ok = math.isfinite(s.choke_dp_pa) and math.isfinite(s.bhp_pa)
        position_ok = math.isfinite(s.string_position_m)
        self.rejected += not (pressures_ok and position_ok)
        if not math.isfinite(s.string_flow_m3s):          # pump off: no balance to keep
            self._first = None
            self._history.clear()
            self._pit.clear()
            self._pit_start = None
            return self._reading(False)
        for window, value in zip(self._pressures, (s.choke_dp_pa, s.bhp_pa)):
            window.add(s.time_s, value if pressures_ok else math.nan)
        current = all(self._pressures)
        if current:
            self._held_pressures = [window.median for window in self._pressures]
            self._pressure_gap_since_s = None
        elif self._pressure_gap_since_s is None:
            self._pressure_gap_since_s = s.time_s
        gap_s = 0.0 if current else s.time_s - self._pressure_gap_since_s
        held_long = not current and bool(self._held_pressures) \
            and gap_s >= self.config.pressure_gap_judged_after_s
        ready = held_long or all(m.full(s.time_s) for m in self._pressures)
        if self._first is None and not (position_ok and ready):
            return self._reading(False)           # the balance starts on a second of readings
        pressures = self._held_pressures
        if self._first is None:                           # (re)start the balance here
            self._first, self._last_time_s, self._integral_m3 = s, s.time_s, 0.0
            self._first_pressures = pressures
        dt = s.time_s - self._last_time_s
        self._last_time_s = s.time_s
        self._integral_m3 += delta_flow_m3s(s) * dt
        if not (position_ok and (current or held_long)):
            # a gauge out: the flows still count, and the known terms catch up with them
            # when it is back; nothing is judged meanwhile
            return self._reading(False)
        known = (self.area_m2 * (s.string_position_m - self._first.string_position_m)
                 + sum(c * (p - p0) for c, p, p0 in zip(self.compliance_m3_pa, pressures,
                                                         self._first_pressures)))
        self._history.append((s.time_s, self._integral_m3 + known, *pressures))
        while self._history[0][0] < s.time_s - self.config.window_s - 1e-9:
            self._history.popleft()
        self._observe_pit(s, known)
        raised = self._judge(s.time_s)
        self._learn(s.time_s, dt)
        return self._reading(raised)

    def _window_rates(self):
        """(raw excess flow m^3/s, regressors of the baseline) over the window; None
        until the window is full."""
        if len(self._history) < 2:
            return None
        (t0, v0, dp0, bhp0), (t1, v1, dp1, bhp1) = self._history[0], self._history[-1]
        span = t1 - t0
        if span < self.config.window_s - 1e-9:
            return None
        return (v1 - v0) / span, FlowBaseline.regressors((dp1 - dp0) / span, (bhp1 - bhp0) / span)

    def _learn(self, time_s: float, dt_s: float) -> None:
        """Fit the baseline on this sample when the well reads quiet: no alarm, nor one on
        its way, and the corrected excess within half the threshold (the clearing level)."""
        window = self._window_rates() if self.baseline is not None else None
        if window is None or self.alarm or any(self._since[k] is not None
                                                for k in ("kick", "losses")):
            return
        raw, phi = window
        if abs(raw - self.baseline.baseline_m3s(phi)) < 0.5 * self.config.flow_threshold_m3s:
            self.baseline.learn(phi, raw, dt_s)

    def _observe_pit(self, s: FlowSample, known_m3: float) -> None:
        """The pit's excess volume: its change since its first reading in this balance, the
        known terms' change out."""
        if self.config.pit_window_s <= 0.0:
            return
        if not math.isfinite(s.pit_volume_m3):
            self.rejected_pit += 1
            return
        if self._pit_start is None:
            self._pit_start = (s.time_s, s.pit_volume_m3, known_m3)
        start_s, pit0, known0 = self._pit_start
        self._pit.append(s.time_s - start_s, s.pit_volume_m3 - pit0 + known_m3 - known0)
        self._pit.drop_before(s.time_s - start_s - self.config.pit_window_s - 1e-9)

    @property
    def pit_gain_flow_m3s(self) -> float:
        """Least-squares slope of the pit's excess volume over the window [m^3/s] (NaN until
        the pit has read for a window since the balance began)."""
        if len(self._pit) < 3 or self._pit.samples[-1][0] < self.config.pit_window_s - 1e-6:
            return math.nan
        return self._pit.slope

    def _judge(self, time_s: float) -> bool:
        """Advance the alarm state on the windowed excess flow; True when raised now.

        The learnt baseline may explain an excess away, never make one: the flow reads
        beyond the threshold only when the balance without the baseline does too (a fit
        learnt while the choke pressure rose, read back as it falls, raised a kick on a
        quiet well: docs/mismatch.md), and quiet when either reads quiet."""
        window = self._window_rates()
        raw = window[0] if window is not None else math.nan
        corrected, pit = self._corrected(window), self.pit_gain_flow_m3s
        if math.isnan(corrected) and math.isnan(pit):
            return False
        threshold, confirm = self.config.flow_threshold_m3s, self.config.confirm_s
        volume = self._history[-1][1]
        for kind, sign in (("kick", 1.0), ("losses", -1.0)):
            beyond = min(sign * corrected, sign * raw) > threshold or sign * pit > threshold
            if not beyond:
                self._since[kind] = None
            elif self._since[kind] is None:
                self._since[kind] = time_s
                self._onset_volume[kind] = self._history[0][1]
        flow = min((corrected, raw), key=abs)
        quiet = all(math.isnan(f) or abs(f) < 0.5 * threshold for f in (flow, pit))
        self._since["clear"] = (self._since["clear"] or time_s) if quiet else None
        if self.alarm and self._since["clear"] is not None \
                and time_s - self._since["clear"] >= confirm:
            self.alarm = ""
        for kind in ("kick", "losses"):
            started = self._since[kind]
            if started is not None and time_s - started >= confirm and self.alarm != kind:
                self.alarm = kind
                self._raised_volume = volume - self._onset_volume[kind]
                return True
        return False

    @property
    def excess_flow_m3s(self) -> float:
        """The windowed excess flow less the learnt baseline [m^3/s] (NaN until a window)."""
        return self._corrected(self._window_rates())

    def _corrected(self, window) -> float:
        """``window``'s (from _window_rates) raw excess less the learnt baseline [m^3/s]."""
        if window is None:
            return math.nan
        raw, phi = window
        return raw - (self.baseline.baseline_m3s(phi) if self.baseline is not None else 0.0)

    def _reading(self, raised: bool) -> Detection:
        volume = self._history[-1][1] if self._history else math.nan
        return Detection(self.excess_flow_m3s, self.pit_gain_flow_m3s, volume, self.alarm, raised,
                         self._raised_volume)


def detector_for(config: RigConfig, geometry: WellGeometry) -> KickDetector:
    """The detector of a well: its net displacement area (steel), and the compliance
    V_i / beta of each annulus volume split between the choke gauge and the bottom gauge by
    its node's depth (the pressure change taken linear in depth), the string's on the
    bottom gauge."""
    beta = config.well.mud.bulk_modulus_pa
    weights = [depth / geometry.node_depth_m[-1] for depth in geometry.node_depth_m]
    volumes = geometry.annulus_volume_m3
    return KickDetector(config.protection.kick_detection,
                        sum(geometry.displacement_area_m2) - geometry.string_top_inner_area_m2,
                        sum(v * (1.0 - w) for v, w in zip(volumes, weights)) / beta,
                        (sum(v * w for v, w in zip(volumes, weights)) + geometry.string_volume_m3)
                        / beta)
