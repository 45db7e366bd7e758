"""The trip sheet of a recorded multi-stand trip (drill_core.tripping.trip_sheet), made
from the rig floor's commands, the measurements and the setpoints in the recording: per
stand slips to slips, out of the slips, peak surge and swab, time outside the BHP band,
expected against measured hole fill and their running difference; the stands per hour,
connections included. The rig's own document, so from the measured BHP and trip tank."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from drill_bag import mcap_io
from drill_core.config import RigConfig
from drill_core.tripping.stands import StandVolumes
from drill_core.tripping.sheet_feed import TripSheetFeed
from drill_core.tripping.trip_sheet import stands_per_hour
from drill_core.units import L_PER_M3, PA_PER_BAR
from drill_core.well import build_geometry
from drill_ros import topic_names as topics
from drill_ros.floor import floor_command, floor_programme
from drill_ros.stamps import seconds_to_ns, to_ns


def trip_sheet(mcap_path: Path, config: RigConfig) -> dict | None:
    """The trip sheet's rows and figures (SI), None when the recording holds no rig floor.
    Each measurement t_k is read with the floor's command for the frame before it, t_k-1
    (the one the plant ran under up to t_k), as the protection keeps its live sheet
    (drill_core.tripping.sheet_feed)."""
    floors, measurements, setpoints = {}, {}, []
    for rec, msg in mcap_io.decoded_messages(mcap_path, [topics.FLOOR, topics.MEASUREMENT,
                                                         topics.SETPOINTS]):
        if rec.topic == topics.FLOOR:
            floors[to_ns(msg.header.stamp)] = msg
        elif rec.topic == topics.MEASUREMENT:
            measurements[to_ns(msg.header.stamp)] = msg
        else:
            setpoints.append((to_ns(msg.header.stamp), msg.bhp_ref_pa, msg.bhp_band_pa))
    if not floors:
        return None
    programme = floor_programme(floors[min(floors)])
    volumes = StandVolumes.of(build_geometry(config.well), programme.stand_length_m)
    feed = TripSheetFeed(programme, volumes, seconds_to_ns(config.plant.sensor_period_s))
    for stamp in sorted(floors):
        feed.floor(stamp, floor_command(floors[stamp]).step)
    setpoints.sort()
    if setpoints:
        feed.reference(math.nan, setpoints[0][2])
    for stamp in sorted(measurements):
        while setpoints and setpoints[0][0] <= stamp:
            feed.reference(*setpoints.pop(0)[1:])
        m = measurements[stamp]
        feed.measurement(stamp, m.bhp_pa, m.trip_tank_volume_m3)
    rows = feed.sheet.rows
    return {"trip_sheet": [dataclasses.asdict(r) for r in rows],
            "stands_tripped": len(rows),
            "stands_per_hour": stands_per_hour(rows),
            "trip_tank_discrepancy_m3": feed.sheet.cumulative_gain_m3,
            "trip_sheet_alarms": [n.code for n in feed.alarms]}


def format_sheet(figures: dict) -> list[str]:
    """The trip sheet as the printed table's lines (display units: s, bar, L)."""
    lines = [f"  trip sheet                    {figures['stands_tripped']} stands, "
             f"{figures['stands_per_hour']:.1f} stands/h (connections included), trip tank "
             f"{figures['trip_tank_discrepancy_m3'] * L_PER_M3:+.0f} L against the steel",
             "    stand  slips to slips  out of slips  surge / swab [bar]  outside band  "
             "fill expected / measured [L]  gain, running [L]"]
    for r in figures["trip_sheet"]:
        lines.append(
            f"    {r['stand']:5d}  {r['end_s'] - r['start_s']:12.0f} s  {r['out_of_slips_s']:10.0f} s  "
            f"{r['peak_surge_pa'] / PA_PER_BAR:8.2f} / {r['peak_swab_pa'] / PA_PER_BAR:5.2f}  "
            f"{r['outside_band_s']:10.0f} s  {r['expected_fill_m3'] * L_PER_M3:12.0f} / "
            f"{r['measured_fill_m3'] * L_PER_M3:5.0f}  "
            f"{r['gain_m3'] * L_PER_M3:+8.0f}, {r['cumulative_gain_m3'] * L_PER_M3:+.0f}")
    if figures["trip_sheet_alarms"]:
        lines.append(f"    alarms: {', '.join(figures['trip_sheet_alarms'])}")
    return lines
