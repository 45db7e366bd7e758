"""The trip sheet: one row per stand, slips to slips, with the time out of and in the
slips, the peak surge and swab, the time BHP spent outside its band, and the hole fill
the trip tank measured against the steel the stand displaced. Their running difference
is the well's gain (+: the well gave back more than the steel, an influx swabbed in;
-: it took more, losses); the sheet raises an alarm when it passes the programme's limit.

The BHP figures judge the gauge's mean over its last BHP_WINDOW_S, not each sample: the
gauge reads 1 bar of noise at 10 Hz, and judged sample by sample a stand held inside its
band would book the gauge's noise as surge, swab and time outside the band.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from drill_core.event_codes import Notice
from drill_core.recent_samples import BHP_WINDOW_S, RecentSamples
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.sequence import DONE, TripStep
from drill_core.tripping.stands import StandVolumes


JUDGED_SHARE = 0.5       # no BHP figure until the gauge's samples span this share of
                         # its window (the start, a gauge just back: one sample alone)


@dataclass(frozen=True)
class StandRow:
    """One stand of the trip, slips to slips (SI)."""
    stand: int
    start_s: float
    end_s: float
    out_of_slips_s: float
    peak_surge_pa: float          # the largest BHP over its reference (0: none)
    peak_swab_pa: float           # the largest BHP under its reference (0: none)
    outside_band_s: float         # BHP outside its band (these three: the gauge's mean)
    expected_fill_m3: float       # the mud the hole should take (- : give back)
    measured_fill_m3: float       # what the trip tank lost (- : gained)
    gain_m3: float                # expected - measured
    cumulative_gain_m3: float

    @property
    def in_slips_s(self) -> float:
        return self.end_s - self.start_s - self.out_of_slips_s


@dataclass
class _OpenRow:
    stand: int
    start_s: float
    tank_start_m3: float
    out_of_slips_s: float = 0.0
    deviation_max_pa: float = -math.inf
    deviation_min_pa: float = math.inf
    outside_band_s: float = 0.0


@dataclass
class TripSheet:
    """Fed every tick; closes a row whenever the sequencer moves to the next stand."""
    programme: TripProgramme
    volumes: StandVolumes
    band_pa: float                 # BHP's band half-width around its reference
    wet: bool = False              # pulled wet: the stand's contents leave with it
    rows: list[StandRow] = field(default_factory=list)
    _gauge: RecentSamples = field(default_factory=lambda: RecentSamples(BHP_WINDOW_S))
    _open: _OpenRow | None = None
    _last_time_s: float | None = None
    _alarm_sign: int = 0

    @property
    def cumulative_gain_m3(self) -> float:
        return self.rows[-1].cumulative_gain_m3 if self.rows else 0.0

    def expected_fill_m3(self) -> float:
        """The fill one stand should take: its steel (or closed end) out, given back in."""
        if self.programme.direction == "out":
            return self.volumes.hole_fill_m3(self.wet)
        return -self.volumes.steel_m3

    def observe(self, time_s: float, step: TripStep, bhp_pa: float, bhp_ref_pa: float,
                tank_volume_m3: float) -> list[Notice]:
        """Take one tick: the sequencer's ``step``, the gauge's BHP and its reference [Pa],
        the trip tank's measured volume [m^3]. Returns the alarms this tick raised."""
        dt = 0.0 if self._last_time_s is None else time_s - self._last_time_s
        self._last_time_s = time_s
        notices = []
        row = self._open
        if row is not None and (step.stand != row.stand or step.phase == DONE):
            notices = self._close(row, time_s, tank_volume_m3)
            row = self._open = None
        if row is None and step.phase != DONE:
            row = self._open = _OpenRow(step.stand, time_s, tank_volume_m3)
        self._gauge.add(time_s, bhp_pa - bhp_ref_pa)
        deviation = self._gauge.mean if self._gauge.spans(time_s, JUDGED_SHARE) else math.nan
        if row is not None and math.isfinite(deviation):
            row.deviation_max_pa = max(row.deviation_max_pa, deviation)
            row.deviation_min_pa = min(row.deviation_min_pa, deviation)
            row.outside_band_s += dt if abs(deviation) > self.band_pa else 0.0
        if row is not None:
            row.out_of_slips_s += 0.0 if step.slips_set else dt
        return notices

    def _close(self, row: _OpenRow, time_s: float, tank_volume_m3: float) -> list[Notice]:
        expected = self.expected_fill_m3()
        measured = row.tank_start_m3 - tank_volume_m3
        gain = expected - measured
        self.rows.append(StandRow(
            stand=row.stand, start_s=row.start_s, end_s=time_s,
            out_of_slips_s=row.out_of_slips_s,
            peak_surge_pa=max(row.deviation_max_pa, 0.0),
            peak_swab_pa=max(-row.deviation_min_pa, 0.0),
            outside_band_s=row.outside_band_s, expected_fill_m3=expected,
            measured_fill_m3=measured, gain_m3=gain,
            cumulative_gain_m3=self.cumulative_gain_m3 + gain))
        return self._judge(time_s)

    def _judge(self, time_s: float) -> list[Notice]:
        total, limit = self.cumulative_gain_m3, self.programme.discrepancy_alarm_m3
        sign = 1 if total > limit else -1 if total < -limit else 0
        raised = sign != 0 and sign != self._alarm_sign
        self._alarm_sign = sign
        if not raised:
            return []
        code = "trip_tank_gain" if sign > 0 else "trip_tank_loss"
        return [Notice(code, f"trip sheet at stand {self.rows[-1].stand}: the well "
                             f"{'gave back' if sign > 0 else 'took'} {abs(total):.3f} m^3 "
                             f"more than the steel (limit {limit:.3f} m^3, t = {time_s:.1f} s)",
                       total)]


def stands_per_hour(rows: list[StandRow]) -> float:
    """Stands tripped per hour of the rows' span, connections included [1/h]."""
    if not rows:
        return 0.0
    return 3600.0 * len(rows) / (rows[-1].end_s - rows[0].start_s)
