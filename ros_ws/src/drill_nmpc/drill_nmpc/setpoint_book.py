"""The setpoints in force for an advisor (the NMPC, automated MPD, the PI baseline): one
book, plain Python.

The scenario's schedule applies by time, each entry once, over the setpoints in force;
an operator request (the /set_setpoints service) merges over them the same way. Both are
validated against the envelope (setpoint_validation) once the BHP target is known; a
refusal changes nothing and says why. The process protection's answer narrows the
envelope's pressure window after a kick or losses, and its BHP target replaces the
reference when the protection holds the well at it (``follow_protection``). A NaN BHP
target means "the BHP of the first estimate" and is resolved by the first finite one.
Every change and refusal comes back as an ``Event`` for the node to publish
(drill_msgs/OperatorEvent), and ``changed`` tells it to re-publish the latched /setpoints.
An advisor plans each sample within the protection's trip-speed limits as well
(``within_speed_limits``: a copy for the plan, the book's setpoints stay the operator's).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from drill_core.event_codes import Notice
from drill_core.input_layout import U_BLOCK
from drill_core.scenario import SETPOINT_FIELDS, ActiveSetpoints, Scenario
from drill_core.units import PA_PER_BAR
from drill_nmpc.setpoint_validation import Envelope, validate_setpoints


@dataclass(frozen=True)
class Event:
    """A change of the setpoints in force, or a refused one (drill_core.event_codes)."""
    notice: Notice

    @property
    def accepted(self) -> bool:
        return self.kind != "refusal"

    @property
    def kind(self) -> str:
        return self.notice.kind      # "setpoint" (accepted) or "refusal"

    @property
    def text(self) -> str:
        return self.notice.text


APPLIED_BLOCK_TOLERANCE_M = 1.0e-3  # the protection's applied block reference this far from
                                    # the advisor's: the protection changed it
HELD_TRIP_PLAN_SPEED_MPS = 1.0e-3  # a held trip (limit 0) is planned at this speed: a
                                   # setpoint limit of 0 would read as none


def protection_changed(applied_block_m: float, ours_m: float) -> bool:
    """The block reference the protection applied [m] (NaN: no answer) is not the one the
    advisor sent or planned, ``ours_m``: it held or slowed the trip."""
    return math.isfinite(applied_block_m) \
        and abs(applied_block_m - ours_m) > APPLIED_BLOCK_TOLERANCE_M



def adopt_applied_block(u_prev, applied_block_m: float | None):
    """The previous input to plan from: the block reference the drawworks was given
    (``applied_block_m``; None, NaN: not known) when the process protection changed ours
    (a trip held on an alarm, a clamp), not the one the advisor sent."""
    if applied_block_m is None or not protection_changed(applied_block_m, u_prev[U_BLOCK]):
        return u_prev
    adopted = u_prev.copy()
    adopted[0] = applied_block_m
    return adopted


def as_delivered(sp: ActiveSetpoints, string_flow_observable: bool) -> ActiveSetpoints:
    """The setpoints with the mud pump planned off while the rig says it delivers nothing
    (a tripped pump: the string-flow meter has no reading) though it is on."""
    if sp.mud_pump_on and not string_flow_observable:
        return dataclasses.replace(sp, mud_pump_on=False)
    return sp

def within_speed_limits(sp: ActiveSetpoints, limits_mps: tuple[float, float],
                        position_m: float) -> ActiveSetpoints:
    """The setpoints to plan a sample with: the trip-speed limit the smaller of the
    operator's and the protection's standing limit (running in, pulling out [m/s], from its
    answer to the last command: 0 for a held trip, the pull-out limit while circulation is
    lost; NaN: none) in the direction of the block target from ``position_m`` (the
    string's, positive up)."""
    limit = limits_mps[1] if sp.block_position_target_m >= position_m else limits_mps[0]
    if not math.isfinite(limit):
        return sp
    operator = sp.trip_speed_limit_mps
    if math.isfinite(operator) and 0.0 < operator <= limit:
        return sp
    return dataclasses.replace(sp, trip_speed_limit_mps=max(limit, HELD_TRIP_PLAN_SPEED_MPS))


def describe(sp: ActiveSetpoints) -> str:
    """The setpoints as an operator reads them (bar, m, m/s)."""
    return (f"BHP {sp.bhp_ref_pa / PA_PER_BAR:.2f} +- {sp.bhp_band_pa / PA_PER_BAR:.2f} bar, choke dp "
            f"{sp.choke_dp_ref_pa / PA_PER_BAR:.2f} +- {sp.choke_dp_band_pa / PA_PER_BAR:.2f} bar, block target "
            f"{sp.block_position_target_m:g} m, trip speed <= {sp.trip_speed_limit_mps:g} m/s, "
            f"controller {'on' if sp.controller_enabled else 'off (manual)'}, mud pump "
            f"{'on' if sp.mud_pump_on else 'off'}")


class SetpointBook:
    def __init__(self, scenario: Scenario, start: ActiveSetpoints, envelope: Envelope):
        self.scenario = scenario
        self.envelope = envelope
        self.active = start
        self.bhp_resolved = False          # the BHP target is known (given, or estimated)
        self.changed = False               # since the node last published the setpoints
        self._next_entry = 0

    @property
    def window_pa(self) -> tuple[float, float]:
        """The BHP window the setpoints keep to [Pa]."""
        return self.envelope.pore_pressure_pa, self.envelope.fracture_pressure_pa

    def follow_protection(self, window_pa: tuple[float, float], bhp_ref_pa: float,
                          sent_bhp_ref_pa: float) -> list[Event]:
        """The protection's answer to a command that carried ``sent_bhp_ref_pa``: its window
        in force (a finite, ordered pair; else ignored) bounds the setpoints from now on;
        its BHP reference, when it is not that echo, is the target it holds the well at,
        taken as the reference with the band narrowed to fit in the window, and the
        choke-dp reference moved as much (the choke dp that holds a BHP moves one for one
        with it: kept where it was, its band would leave no room to run in against the
        surge under a lowered target)."""
        low, high = (float(v) for v in window_pa)
        if math.isfinite(low) and math.isfinite(high) and low < high:
            self.envelope = dataclasses.replace(self.envelope, pore_pressure_pa=low,
                                                fracture_pressure_pa=high)
        echo = bhp_ref_pa in (sent_bhp_ref_pa, self.active.bhp_ref_pa)
        if not math.isfinite(bhp_ref_pa) or echo:
            return []
        low, high = self.window_pa
        band = min(self.active.bhp_band_pa, bhp_ref_pa - low, high - bhp_ref_pa)
        shift = bhp_ref_pa - self.active.bhp_ref_pa if math.isfinite(self.active.bhp_ref_pa) \
            else 0.0
        dp_ref = min(max(self.active.choke_dp_ref_pa + shift, 0.0), self.envelope.choke_dp_max_pa)
        candidate = dataclasses.replace(self.active, bhp_ref_pa=float(bhp_ref_pa),
                                        bhp_band_pa=band, choke_dp_ref_pa=dp_ref)
        ok, reason = validate_setpoints(candidate, self.envelope)
        window = f"window {low / PA_PER_BAR:.1f}-{high / PA_PER_BAR:.1f} bar"
        if not ok:
            return [Event(Notice("well_control_refused", f"protection: well-control target "
                                                         f"refused ({window}): {reason}"))]
        self.active = candidate
        self.bhp_resolved = True
        self.changed = True
        return [Event(Notice("well_control_setpoints", f"protection: well control ({window}): "
                                                       f"{describe(candidate)}", bhp_ref_pa))]

    def advance(self, t_s: float) -> list[Event]:
        """Apply every schedule entry due by scenario time ``t_s``, in order."""
        events = []
        applied = False
        schedule = self.scenario.schedule
        while self._next_entry < len(schedule) and schedule[self._next_entry].time_s <= t_s + 1e-9:
            entry = schedule[self._next_entry]
            self._next_entry += 1
            candidate = dataclasses.replace(self.active, **entry.changes(SETPOINT_FIELDS))
            if math.isfinite(candidate.bhp_ref_pa):
                ok, reason = validate_setpoints(candidate, self.envelope)
                if not ok:
                    events.append(Event(Notice("schedule_refused", f"scenario entry at "
                                                   f"{entry.time_s:g} s refused: {reason}")))
                    continue
            self.active = candidate
            applied = True
        if applied and self.bhp_resolved:
            events.append(self._schedule_event())
            self.changed = True
        return events

    def resolve_bhp(self, bhp_pa: float) -> list[Event]:
        """A NaN BHP target becomes ``bhp_pa`` (the first finite estimate's); the first
        call with a finite value announces the setpoints in force."""
        if self.bhp_resolved or not math.isfinite(bhp_pa):
            return []
        if not math.isfinite(self.active.bhp_ref_pa):
            self.active = dataclasses.replace(self.active, bhp_ref_pa=float(bhp_pa))
        self.bhp_resolved = True
        self.changed = True
        return [self._schedule_event()]

    def _schedule_event(self) -> Event:
        return Event(Notice("schedule_setpoints", f"scenario: {describe(self.active)}",
                            self.active.bhp_ref_pa))

    def request(self, candidate: ActiveSetpoints, source: str) -> tuple[bool, str, Event]:
        """An operator request, already merged over the setpoints in force."""
        if not math.isfinite(candidate.bhp_ref_pa):
            ok, reason = False, "bhp_ref_pa is not set yet (no estimate received): give a value"
        else:
            ok, reason = validate_setpoints(candidate, self.envelope)
        if not ok:
            return False, reason, Event(Notice("setpoints_refused", f"{source}: refused: {reason}"))
        self.active = candidate
        self.bhp_resolved = True
        self.changed = True
        return True, reason, Event(Notice("setpoints_accepted", f"{source}: {describe(candidate)}",
                                          candidate.bhp_ref_pa))
