"""The process protection's answer to an unplanned loss of circulation, a mud-pump trip
(plain Python; docs/design.md §10, docs/faults.md).

Found from measured signals only: the advisor's command asks for the mud pump (on, with
a stand-pipe pressure) while the string-flow meter, which read a flow before, reads
nothing. The scenario's fault and the truth are not read; a pump the advisor stops (a
connection) is not a loss.

While circulation stays lost:

* the back-pressure pump runs at least ``bpp_flow_m3s``: with the rig pump gone the
  choke has no flow to hold back-pressure with but this one (what an MPD crew does);
* once, from the loss: the annular friction that goes with the circulation is made good
  by the choke. Its flow reference is held at zero, so that it closes and traps what the
  winding-down pump still delivers (and the back-pressure pump's flow), while the BHP the
  well will have once the friction is gone - the mud column plus the measured choke dp -
  is under the window's low edge (pore pressure plus the protection's margin) plus
  ``static_margin_pa``; for at most ``trap_max_s``, and never while the BHP is at the
  window's fracture edge (the window guard relieves it there).

A gauge the protection cannot read (a dropout, or frozen: drill_protection.reading) is
made good by the other through the steady model's annular friction at the measured flow up
the annulus and string speed (drill_protection.surface_bhp): without the choke dp the BHP
without friction is the measured BHP less that friction, without the BHP the BHP is the
mud column plus the choke dp plus it.

``request`` takes each advisor command, ``observe`` every measurement (it says when
circulation is lost or back); ``action`` gives, at each command, what the limiter must
apply (drill_protection.protection).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drill_core import hydraulics as hy
from drill_core.config import PumpTrip
from drill_core.event_codes import Notice
from drill_core.units import PA_PER_BAR
from drill_protection.surface_bhp import SurfaceBhp


@dataclass(frozen=True)
class TripAction:
    """What the protection applies while circulation is lost (SI)."""
    choke_flow_m3s: float | None    # the choke's flow reference while the friction is made
                                    # good; None: the advisor's choke command stands
    bpp_flow_min_m3s: float         # the back-pressure pump runs at least this
    reason: str
    friction_free_bhp_pa: float = float("nan")  # the BHP once the annular friction is gone
                                                # (mud column + measured choke dp) [Pa]


class PumpTripResponse:
    """Circulation watch and the response to its unplanned loss, for one run."""

    def __init__(self, config: PumpTrip, wm: hy.WellModel, window_pa: tuple[float, float]):
        self.config = config
        self.window_pa = window_pa
        self.surface = SurfaceBhp(wm)
        self.requested = False           # the last command asks for the mud pump
        self.circulated = False          # the string-flow meter has read a flow
        self.lost_at_s: float | None = None
        self.trapping = False            # the friction is being made good by the choke
        self.choke_dp_pa = math.nan
        self.bhp_pa = math.nan
        self.friction_pa = math.nan      # the model's annular friction at the measured flow

    def request(self, mud_pump_on: bool, spp_pa: float) -> None:
        """The advisor's command: does it ask for circulation?"""
        self.requested = bool(mud_pump_on) and spp_pa > 0.0

    def observe(self, time_s: float, string_flow_valid: bool, choke_dp_pa: float,
                bhp_pa: float, annulus_flow_m3s: float = math.nan,
                string_velocity_mps: float = 0.0) -> Notice | None:
        """Take one measurement (the flow up the annulus [m^3/s] and the string's speed, up
        [m/s], are read only while circulation is lost or the BHP is unread); the alarm
        when circulation is found lost or back (None otherwise)."""
        self.choke_dp_pa, self.bhp_pa = choke_dp_pa, bhp_pa
        notice = None
        if string_flow_valid:
            self.circulated = True
            if self.lost_at_s is not None:
                self.lost_at_s, self.trapping = None, False
                notice = Notice("circulation_restored",
                                "circulation back: the string-flow meter reads a flow again")
        elif self.lost_at_s is None and self.requested and self.circulated:
            self.lost_at_s, self.trapping = time_s, True
            notice = Notice("circulation_lost", "circulation lost: the mud pump is asked for "
                                                "but the string-flow meter reads nothing "
                                                "(pump trip)")
        needed = self.lost_at_s is not None or not math.isfinite(bhp_pa)
        self.friction_pa = self.surface.friction_pa(annulus_flow_m3s, string_velocity_mps) \
            if needed else math.nan
        return notice

    @property
    def lost(self) -> bool:
        """Circulation is lost now."""
        return self.lost_at_s is not None

    def friction_free_bhp_pa(self) -> float:
        """The BHP the well will have once the annular friction is gone [Pa]: the mud
        column plus the measured choke dp; without it, the measured BHP less the model's
        friction."""
        if math.isfinite(self.choke_dp_pa):
            return self.surface.column_pa + self.choke_dp_pa
        return self.bhp_pa - self.friction_pa

    def judged_bhp_pa(self) -> float:
        """The BHP [Pa] of the last measurement: measured, else the BHP without friction
        plus the model's friction (the window guard's BHP, too)."""
        if math.isfinite(self.bhp_pa):
            return self.bhp_pa
        return self.friction_free_bhp_pa() + self.friction_pa

    def action(self, time_s: float) -> TripAction | None:
        """What to apply with the command at ``time_s`` (None: circulation is not lost, or
        the advisor no longer asks for the pump)."""
        if self.lost_at_s is None or not self.requested:
            return None
        c = self.config
        low, high = self.window_pa
        static, bhp = self.friction_free_bhp_pa(), self.judged_bhp_pa()
        since = time_s - self.lost_at_s
        if self.trapping and (since > c.trap_max_s or (math.isfinite(static)
                                                        and static >= low + c.static_margin_pa)):
            self.trapping = False           # once: the friction is made good (or given up)
        why = f"circulation lost {since:.0f} s ago"
        if self.trapping and math.isfinite(static) and math.isfinite(bhp) and bhp < high:
            return TripAction(0.0, c.bpp_flow_m3s,
                              f"{why}: BHP without friction {static / PA_PER_BAR:.1f} bar under "
                              f"{(low + c.static_margin_pa) / PA_PER_BAR:.1f} bar: choke held shut",
                              static)
        return TripAction(None, c.bpp_flow_m3s, why, static)
