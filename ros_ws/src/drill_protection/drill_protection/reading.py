"""The measurement the protection reads (plain Python): drill_msgs/RigMeasurement's
fields it uses, with each gauge found frozen (drill_core.channel_watch: a live gauge's
noise never repeats a float) left out as NaN, so that every rule reads a frozen gauge as
it reads a dropout. ``ReadingScreen.observe`` takes each measurement in stamp order and
updates the flags; ``ReadingScreen.of`` screens a measurement with the flags in force."""
from __future__ import annotations

import math
from dataclasses import dataclass

from drill_core.channel_watch import ChannelWatch
from drill_core.event_codes import Notice

SCREENED = ("block_position_m", "choke_dp_pa", "bhp_pa", "return_flow_m3s", "bpp_flow_m3s",
            "pit_volume_m3")


@dataclass(frozen=True)
class Reading:
    """One measurement as the protection reads it (SI; NaN: no usable sample)."""
    block_position_m: float       # the block's position, up [m]
    choke_dp_pa: float            # choke differential pressure [Pa]
    bhp_pa: float                 # bottom-hole pressure [Pa]
    return_flow_m3s: float        # the choke line's Coriolis meter [m^3/s]
    bpp_flow_m3s: float           # back-pressure pump flow [m^3/s]
    pit_volume_m3: float          # active pit volume [m^3]
    string_flow_m3s: float        # the string-flow meter [m^3/s] (NaN without circulation)
    string_flow_valid: bool       # the string-flow meter reads a flow
    trip_tank_volume_m3: float    # the trip tank's level [m^3] (not screened: read per stand)


class ReadingScreen:
    """Frozen-gauge flags over the measurements, and the screened readings."""

    def __init__(self, frozen_after_samples: int):
        self.watch = ChannelWatch(SCREENED, frozen_after_samples)
        self.frozen: tuple[str, ...] = ()

    def observe(self, time_s: float, m) -> list[Notice]:
        """Take one measurement: a notice for each gauge found frozen or live again."""
        _, now = self.watch.screen(time_s, [getattr(m, name) for name in SCREENED])
        notices = [Notice("gauge_frozen", f"{name} repeats its value: read as a dropout")
                   for name in now if name not in self.frozen]
        notices += [Notice("gauge_live", f"{name} moves again")
                    for name in self.frozen if name not in now]
        self.frozen = now
        return notices

    def of(self, m) -> Reading:
        """``m`` as the protection reads it: the gauges flagged frozen NaN."""
        return Reading(**{name: math.nan if name in self.frozen else float(getattr(m, name))
                          for name in SCREENED},
                       string_flow_m3s=float(m.string_flow_m3s),
                       string_flow_valid=bool(m.string_flow_valid),
                       trip_tank_volume_m3=float(m.trip_tank_volume_m3))
