"""Process protection (the D-WIS model, docs/design.md §10): whatever an advisor (the
NMPC, the baseline controller or the operator) asks, the command that reaches the
machines respects the most conservative of

* machine limits: actuator ranges and rate limits,
* operator limits: the trip-speed limit of the setpoints in force,
* the emergency stop, which acts at the machines: the command says so
  (``Decision.emergency_stop``), the drawworks sets its brake (the block decelerates at
  its brake limit to rest and is held) and the choke holds the BHP of the stop on its own
  BHP loop: the BHP measured at the press (the median of its last second), or while a
  kick or loss is answered the answer's target, whose steps go on during the stop (the
  stop stops the block, not the well control); kept inside the window in force. The loop
  starts from the choke dp the model says the stop calls for (the measured one less the
  surge/swab of the string's speed at the stop, which goes with it), its flow feedforward
  the flow out of a well at rest (circulation plus back-pressure pump), the pumps held
  where they were but for a lost circulation's back-pressure pump floor (without
  circulation the steady model's swab is not the friction that goes, so there is no
  feedforward then); the block
  reference follows the measured string, so that the release hands back from where the
  string is, at rest, without a jump,
* model-derived surge/swab limits: the largest trip speed, each way, for which the
  steady Herschel-Bulkley surge/swab model keeps the BHP inside the pore/fracture
  window (with margin), and a limit on the change of trip speed (acceleration),
* the pressure window itself (``window_guard``): while the measured BHP is over the
  fracture pressure less the margin, or heading over it within ``window_guard_lead_s`` on
  its least-squares slope over as long (a pump ramped up under a choke closed on the
  friction the connection took away: the choke's answer takes that long), the choke's
  flow reference is set above the measured return flow by one slew or, if more, by the
  flow that takes the BHP ahead back to the edge over the lead (the annulus's compliance
  times the overshoot over the lead: 13 bar on the reference well is 370 L/min), and the
  back-pressure pump one slew below its measured flow
  (unless the advisor asks for more of that), the other way round under the pore
  pressure plus the margin (the choke on its flow loop while it acts). Starting from the
  measured flows, not the last commands, it cannot wind up behind the pumps' lags,
* a confirmed kick or loss (drill_protection.well_control): while the advisor's BHP
  reference is outside the window that answer narrowed, the choke held on its pressure
  loop at the set-point that puts BHP at the target inside it, whatever the advisor asks
  for the choke, and that target handed to the advisor as the reference in force; the
  trip-speed limits kept to the narrowed window,
* an unplanned loss of circulation (drill_protection.pump_trip): the back-pressure pump
  kept at a flow the choke can hold back-pressure with, and once the choke held shut
  while the BHP the well will have without the annular friction is under the window; a
  string pulled faster than the swab limit from that BHP (and than coming to rest) when
  the loss is found has its block reference put at the string at once, not braked down
  the acceleration limit,
* a drawworks that does not follow its reference (drill_protection.actuator_watch): the
  block reference held at the measured string, at rest, so that a stuck block does not
  catch up at the drawworks' speed limit when it lets go,
* a choke that does not follow its flow reference, or a back-pressure pump that does not
  deliver, while circulation is lost: nothing can then make good the friction the mud pump
  took with it but a string at rest and what the choke traps, so the protective stop sets
  the drawworks brake and the choke's BHP loop as the emergency stop does, with the
  back-pressure pump at its maximum, until the choke moves again (the pump delivers again)
  or circulation is back.

A manual choke opening (choke panel in manual) is kept inside the choke's range; its
rate is limited by the choke actuator's own lag. A choke-dp set-point (the choke on its
pressure loop) passes when finite and the choke dp is read; a non-finite one, or one the
choke cannot follow for want of a usable choke-dp reading (a dropout, a frozen gauge),
puts the choke back on its flow loop at the advisor's flow (the pressure loop's
feedforward).
Both are held, like the pressures, outside closed loop.

Every clamp is reported with its reason. Plain Python; the node wires it to topics.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drill_core import hydraulics as hy
from drill_core.config import RigConfig
from drill_core.event_codes import Notice
from drill_core.input_layout import COMMAND_NAMES, U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE
from drill_core.recent_samples import BHP_WINDOW_S, RecentSamples
from drill_core.units import PA_PER_BAR
from drill_protection.pump_trip import TripAction
from drill_protection.slope import LeastSquaresSlope
from drill_protection.well_control import Hold

_SPEED_GRID_POINTS = 61
RESTING_REFERENCE_SPEED_MPS = 0.05   # a block reference slower than this is coming to rest


@dataclass(frozen=True)
class Decision:
    """The command that goes to the machines and why it differs from the request."""
    command: np.ndarray                 # [u_r m, q_c m^3/s, q_bpp m^3/s, p_spp Pa]
    clamps: tuple[Notice, ...]          # one per limit that acted (drill_core.event_codes)
    trip_speed_limits_mps: tuple[float, float]  # allowed speed running in, pulling out
    manual_choke_opening: float | None = None   # choke in manual at this opening [1]; None: PI
    choke_dp_setpoint: tuple[float, float] | None = None  # pressure loop: (dp set-point Pa,
                                                          # its ramp Pa/s); None: not in force
    bhp_ref_pa: float = float("nan")    # the BHP reference in force: the advisor's, or the
                                        # well-control target while the protection holds [Pa]
    standing_speed_limits_mps: tuple[float, float] = (float("inf"), float("inf"))
                                        # the standing part of trip_speed_limits_mps
                                        # (SpeedLimits.standing_mps): the advisors plan within it
    emergency_stop: bool = False        # the brake set and the choke on its BHP loop
    emergency_bhp_pa: float = float("nan")  # the BHP the choke holds under it [Pa]
    emergency_dp_start_pa: float = float("nan")  # its BHP loop's first choke-dp set-point [Pa]


@dataclass(frozen=True)
class SpeedLimits:
    """The protection's trip-speed limits at one command [m/s], each with its reason."""
    running_in: tuple[float, str]
    pulling_out: tuple[float, str]
    standing_mps: tuple[float, float]   # (running in, pulling out): the limits that last -
                                        # the operator's and machine cap, 0 for a trip held on
                                        # an alarm, the limits from the BHP without friction
                                        # while circulation is lost - not the surge/swab
                                        # clamp of each BHP reading nor the hold for a
                                        # reading without a BHP


def surge_swab_pa(wm: hy.WellModel, speeds_mps: np.ndarray, circulation_m3s: float) -> np.ndarray:
    """Steady change of BHP [Pa] when the string moves at ``speeds_mps`` (positive up) with
    a closed-end string, relative to the string at rest, at the given circulation."""
    area = wm.geometry.string_outer_area_at_top_m2
    speeds = np.asarray(speeds_mps, dtype=float)
    flows = [circulation_m3s - area * speeds] * (wm.n - 1)
    moving = np.sum(hy.annulus_friction(np, wm, flows, speeds), axis=0)
    still = np.sum(hy.annulus_friction(np, wm, [np.array([circulation_m3s])] * (wm.n - 1),
                                       np.zeros(1)), axis=0)
    return moving - still


class ProcessProtection:
    """Stateful limiter: remembers the last applied command for rate limits."""

    def __init__(self, config: RigConfig, wm: hy.WellModel, initial_command: np.ndarray):
        self.config = config
        self.wm = wm
        self.previous = np.asarray(initial_command, dtype=float).copy()
        self.previous_manual_opening: float | None = None
        self.previous_dp_setpoint: tuple[float, float] | None = None
        self.previous_speed_mps = 0.0
        self.emergency_stop = False
        self.protective_stop = False            # circulation lost, the choke stuck: braked
        self.circulation_lost = False           # a trip action at the last command
        self.emergency_bhp_pa = float("nan")    # BHP the stop holds [Pa]; NaN: no stop
        self.pressed_bhp_pa = float("nan")      # the measured BHP at the press [Pa]
        self.emergency_dp_start_pa = float("nan")   # the choke dp the stop calls for [Pa]
        self.last_bhp_pa = float("nan")         # the last finite BHP measurement [Pa]
        self.bhp_gauge = RecentSamples(BHP_WINDOW_S)     # every measurement's BHP (observe_bhp)
        self.bhp_trend = LeastSquaresSlope()    # the last window_guard_lead_s of them
        self.automation_level = "closed_loop"
        self.trip_hold = ""          # why the trip is stopped (a well-control alarm), "" if not
        # a kick or losses answered (drill_protection.well_control): the window the trip
        # speed limits keep to, and the hold while the advisor aims outside it (None: none)
        self.window_pa = config.pressure_window_pa
        self.well_control: Hold | None = None
        self.bhp_ref_pa = float("nan")      # the BHP reference in force after the last command [Pa]
        a, n = config.actuators, config.nmpc
        self.lower = np.array([a.drawworks.minimum, 0.0, a.bpp.minimum, a.mud_pump.minimum])
        self.upper = np.array([a.drawworks.maximum, n.input_max.choke_flow_m3s, a.bpp.maximum,
                               a.mud_pump.maximum])
        self.slew = np.array(n.input_slew.as_tuple())
        self.annulus_compliance_m3_per_pa = hy.annulus_compliance_m3_per_pa(wm)

    def speed_limits(self, bhp_pa: float, string_velocity_mps: float, circulation_m3s: float,
                     operator_limit_mps: float, friction_free_bhp_pa: float = float("nan")
                     ) -> SpeedLimits:
        """Allowed trip speed [m/s] running in and pulling out, each with the limit that set
        it, and the standing part of them.

        The measured BHP is first referred back to the string at rest with the model at
        the measured string velocity, then the model predicts BHP at each candidate speed.
        While circulation is lost, both sides also start from ``friction_free_bhp_pa`` (the
        BHP once the winding-down pump's friction is gone: drill_protection.pump_trip), so
        the string is not pulled on friction that is going, nor run in on a surge the model
        credits the measurement with: without circulation the model's surge is the mud's
        yield, almost all of it at the first cm/s (20.6 of 26.8 bar at 0.035 of 0.5 m/s),
        while the measured BHP builds it only as the mud moves. Those limits stand until the
        choke has made the friction good, as a held trip and the operator's and machine
        limits do (``SpeedLimits.standing_mps``).
        """
        p = self.config.protection
        if self.trip_hold:
            held = (0.0, self.trip_hold)
            return SpeedLimits(held, held, (0.0, 0.0))
        machine = min(p.trip_speed_max_mps, self.config.actuators.drawworks.rate_limit_per_s)
        cap, cap_reason = (operator_limit_mps, "operator trip-speed limit") \
            if operator_limit_mps < machine else (machine, "drawworks machine limit")
        if not (np.isfinite(bhp_pa) and np.isfinite(string_velocity_mps)):
            held = (0.0, "no finite BHP or string-speed measurement: trip held")
            return SpeedLimits(held, held, (float(cap), float(cap)))   # held for this reading
        grid = np.linspace(0.0, cap, _SPEED_GRID_POINTS)
        # one model evaluation: the measured speed, then the grid running in and pulling out
        change = surge_swab_pa(self.wm, np.concatenate([[string_velocity_mps], -grid, grid]),
                               circulation_m3s)
        static_bhp = bhp_pa - change[0]
        low, high = self.window_pa
        surge, swab = change[1:1 + grid.size], change[1 + grid.size:]

        def allowed(part, start: float, word: str) -> tuple[float, str]:
            bhp = start + part
            # a speed is acceptable if it keeps BHP in the window or moves it toward the window
            outside = np.maximum(low - bhp, 0.0) + np.maximum(bhp - high, 0.0)
            ok = outside <= max(low - start, 0.0) + max(start - high, 0.0)
            if ok.all():
                return float(cap), f"{cap_reason} {cap:.2f} m/s"
            speed = float(grid[max(int(np.argmin(ok)) - 1, 0)])
            return speed, (f"{word} model keeps BHP inside {low / PA_PER_BAR:.1f}-{high / PA_PER_BAR:.1f} bar "
                           f"only up to {speed:.2f} m/s")

        down, up = allowed(surge, static_bhp, "surge"), allowed(swab, static_bhp, "swab")
        standing = (float(cap), float(cap))
        if np.isfinite(friction_free_bhp_pa):
            lost_down = allowed(surge, friction_free_bhp_pa, "circulation lost: surge")
            lost_up = allowed(swab, friction_free_bhp_pa, "circulation lost: swab")
            standing = (lost_down[0], lost_up[0])
            down, up = min(down, lost_down), min(up, lost_up)
        return SpeedLimits(down, up, standing)

    def apply(self, request, position_m: float, string_velocity_mps: float, bhp_pa: float,
              circulation_m3s: float, operator_speed_limit_mps: float,
              manual_choke_opening: float | None = None,
              choke_dp_setpoint: tuple[float, float] | None = None,
              surface_flows: tuple[float, float] | None = None,
              trip_action: TripAction | None = None,
              advisor_bhp_ref_pa: float = float("nan"),
              choke_dp_pa: float = float("nan"), block_not_following: bool = False,
              choke_not_following: bool = False, choke_moving: bool = True,
              bpp_not_delivering: bool = False,
              surface_bhp_pa: float = float("nan")) -> Decision:
        """Limit ``request`` [u_r, q_c, q_bpp, p_spp], the requested manual choke opening and
        choke-dp set-point (dp Pa, ramp Pa/s) (both None: the choke on its PI flow
        controller; a manual opening wins); ``surface_flows`` are the measured return and
        back-pressure pump flows [m^3/s] the window guard starts from; ``trip_action`` the
        answer to a lost circulation (drill_protection.pump_trip), None when there is
        none; ``advisor_bhp_ref_pa`` the BHP the advisor aims at (NaN: none);
        ``choke_dp_pa`` the measured choke dp (the emergency stop's feedforward);
        ``block_not_following``, ``choke_not_following``, ``choke_moving`` and
        ``bpp_not_delivering`` the actuator watches' judgements; ``surface_bhp_pa`` the
        BHP judged from the surface (drill_protection.surface_bhp, kept by the circulation
        watch) the window guard reads when ``bhp_pa`` is unread. Returns the command to
        send and why."""
        p = self.config.protection
        period = p.command_period_s
        request = np.asarray(request, dtype=float)
        clamps: list[Notice] = []
        if not np.all(np.isfinite(request)):
            clamps.append(Notice("non_finite_request", "non-finite request: holding the last command"))
            request = self.previous.copy()
        if manual_choke_opening is not None and not np.isfinite(manual_choke_opening):
            clamps.append(Notice("non_finite_manual_choke",
                                 "non-finite manual choke opening: holding the last choke mode"))
            manual_choke_opening = self.previous_manual_opening
        if np.isfinite(bhp_pa):
            self.last_bhp_pa = float(bhp_pa)
        self.protective_stop = trip_action is not None and not self.emergency_stop and (
            choke_not_following or bpp_not_delivering
            or (self.protective_stop and not choke_moving))
        protective = self.protective_stop
        stop = self.emergency_stop or protective
        stopped = self._emergency_bhp(stop, string_velocity_mps, circulation_m3s, choke_dp_pa)
        not_applied = stop or self.automation_level != "closed_loop"
        if protective:
            machine = "the back-pressure pump does not deliver" if bpp_not_delivering \
                else "the choke does not follow its flow reference"
            clamps.append(Notice("protective_stop", f"circulation lost and {machine}: advisor "
                                 "command not applied, drawworks brake set, back-pressure pump "
                                 "at its maximum", stopped))
        elif self.emergency_stop:
            clamps.append(Notice("estop_hold", f"emergency stop: advisor command not applied, "
                                 f"drawworks brake set, BHP held at {stopped / PA_PER_BAR:.1f} "
                                 "bar by the choke", stopped))
        if stop:
            request = self.previous.copy()
            request[U_BLOCK] = position_m if np.isfinite(position_m) else self.previous[U_BLOCK]
            manual_choke_opening, choke_dp_setpoint = None, None
        elif not_applied:
            clamps.append(Notice("level_hold", f"automation level {self.automation_level}: "
                                 "advisor command not applied, block held at rest, pressures held"))
            request = self.previous.copy()
            manual_choke_opening = self.previous_manual_opening
            held = self.previous_dp_setpoint
            choke_dp_setpoint = (held[0], 0.0) if held is not None else None
        elif choke_dp_setpoint is not None and not np.all(np.isfinite(choke_dp_setpoint)):
            clamps.append(Notice("non_finite_dp_setpoint", f"non-finite choke dp set-point "
                                 f"{choke_dp_setpoint[0]} Pa: choke on its flow controller"))
            choke_dp_setpoint = None
        elif choke_dp_setpoint is not None and not np.isfinite(choke_dp_pa):
            clamps.append(Notice("dp_setpoint_unread", "no usable choke-dp reading: the choke-dp "
                                 "set-point cannot be followed, the choke on its flow "
                                 "controller at the advisor's flow"))
            choke_dp_setpoint = None
        held_block = block_not_following and not not_applied
        if held_block:
            request[U_BLOCK] = position_m if np.isfinite(position_m) else self.previous[U_BLOCK]
            clamps.append(Notice("drawworks_not_following", "the block did not follow its "
                                 "reference: the reference held at the string, "
                                 f"{request[U_BLOCK]:.2f} m", float(request[U_BLOCK])))
        command = request.copy()
        manual_choke_opening = self._limit_opening(manual_choke_opening, clamps)
        if manual_choke_opening is not None:
            choke_dp_setpoint = None

        bhp_ref_pa = advisor_bhp_ref_pa
        low, high = self.window_pa
        aims_inside = bool(low <= advisor_bhp_ref_pa <= high)      # False for NaN
        if self.well_control is not None and not not_applied and not aims_inside:
            hold = self.well_control
            manual_choke_opening, choke_dp_setpoint = None, (hold.choke_dp_pa, 0.0)
            flowing = (surface_flows or (np.nan,))[0]      # the pressure loop's feed-forward
            command[U_CHOKE] = flowing if np.isfinite(flowing) else self.previous[U_CHOKE]
            clamps.append(Notice("well_control_hold", hold.reason, hold.target_bhp_pa))
            bhp_ref_pa = hold.target_bhp_pa
        trip = None if not_applied and not stop else trip_action
        friction_free = trip.friction_free_bhp_pa if trip is not None else float("nan")
        resting = abs(self.previous_speed_mps) < RESTING_REFERENCE_SPEED_MPS
        judged, measured = (bhp_pa, True) if np.isfinite(bhp_pa) else (surface_bhp_pa, False)
        guard = self._window_guard(judged, clamps, friction_free if resting else float("nan"),
                                   measured=measured)
        shut = trip is not None and trip.choke_flow_m3s is not None and not stop
        if guard or shut:
            manual_choke_opening, choke_dp_setpoint = None, None

        for i in (U_CHOKE, U_BPP_FLOW, U_PUMP_PRESSURE):
            limited = np.clip(command[i], self.previous[i] - self.slew[i], self.previous[i] + self.slew[i])
            limited = float(np.clip(limited, self.lower[i], self.upper[i]))
            if limited != command[i] and not (guard and i in (U_CHOKE, U_BPP_FLOW)) \
                    and not (shut and i == U_CHOKE):
                clamps.append(Notice("machine_limit", f"{COMMAND_NAMES[i]} {command[i]:.6g} -> "
                                     f"{limited:.6g} (machine range/rate)"))
            command[i] = limited
        if guard:
            self._drive_back(guard, command, surface_flows, circulation_m3s,
                             self._relief_m3s(guard, judged, measured))
        if trip is not None:
            self._answer_trip(trip, guard, command, clamps, shut)
        if protective and guard <= 0:
            command[U_BPP_FLOW] = self.upper[U_BPP_FLOW]
        if stop and not guard:      # the BHP loop's feedforward: the flow out at rest
            command[U_CHOKE] = min(circulation_m3s + command[U_BPP_FLOW], self.upper[U_CHOKE])

        limits = self.speed_limits(bhp_pa, string_velocity_mps, circulation_m3s,
                                   operator_speed_limit_mps, friction_free)
        (down, why_down), (up, why_up) = limits.running_in, limits.pulling_out
        newly_lost, self.circulation_lost = trip is not None and not self.circulation_lost, \
            trip is not None
        if newly_lost and not (stop or held_block) and np.isfinite(position_m) \
                and self.previous_speed_mps > max(limits.standing_mps[1],
                                                  RESTING_REFERENCE_SPEED_MPS) \
                and position_m < command[U_BLOCK]:
            held_block = True         # pulled faster than the friction that goes allows
            command[U_BLOCK] = position_m
            command[U_BPP_FLOW] = self.upper[U_BPP_FLOW]
            clamps.append(Notice("lost_circulation_hold", "circulation lost while pulling out "
                                 f"faster than {limits.standing_mps[1]:.2f} m/s: the block "
                                 f"reference held at the string, {position_m:.2f} m, the "
                                 "back-pressure pump to its maximum", position_m))
        speed = (command[U_BLOCK] - self.previous[U_BLOCK]) / period
        if stop or held_block:       # to where the string is, at once
            limited_speed = speed
        else:
            accel = p.trip_acceleration_max_mps2 * period
            lowest = max((-down, why_down), (self.previous_speed_mps - accel, "acceleration limit"))
            highest = min((up, why_up), (self.previous_speed_mps + accel, "acceleration limit"))
            limited_speed = float(np.clip(speed, lowest[0], max(lowest[0], highest[0])))
            if limited_speed != speed:
                why = lowest[1] if limited_speed == lowest[0] else highest[1]
                clamps.append(Notice("speed_clamp", f"block reference speed {speed:+.3f} -> "
                                     f"{limited_speed:+.3f} m/s ({why})", limited_speed))
        ref = self.previous[U_BLOCK] + limited_speed * period
        ref = float(np.clip(ref, self.lower[U_BLOCK], self.upper[U_BLOCK]))
        if ref != self.previous[U_BLOCK] + limited_speed * period:
            clamps.append(Notice("drawworks_range", "block reference held inside the drawworks "
                                 "range", ref))
        command[U_BLOCK] = ref
        self.previous_speed_mps = 0.0 if stop or held_block \
            else (ref - self.previous[U_BLOCK]) / period
        self.previous = command.copy()
        self.previous_manual_opening = manual_choke_opening
        self.previous_dp_setpoint = choke_dp_setpoint
        self.bhp_ref_pa = float(bhp_ref_pa)
        return Decision(command, tuple(clamps), (down, up), manual_choke_opening,
                        choke_dp_setpoint, float(bhp_ref_pa), limits.standing_mps,
                        stop, stopped, self.emergency_dp_start_pa)

    def observe_bhp(self, time_s: float, bhp_pa: float) -> None:
        """Take every BHP measurement (the stop's BHP is the median of the last second's;
        the window guard's trend the slope of the last ``window_guard_lead_s``)."""
        self.bhp_gauge.add(time_s, bhp_pa)
        if np.isfinite(bhp_pa):
            self.bhp_trend.append(time_s, float(bhp_pa))
        self.bhp_trend.drop_before(time_s - self.config.protection.window_guard_lead_s + 1e-9)

    def _emergency_bhp(self, stop: bool, string_velocity_mps: float, circulation_m3s: float,
                       choke_dp_pa: float) -> float:
        """The BHP the choke holds under the emergency stop [Pa], NaN without one: the
        well-control answer's target while one is held, else the measured BHP when the stop
        came in (the median of its last second, the last sample without one); inside the
        window in force (so a stop while the window is being made good still ends inside
        it). From the press on, the choke dp the stop calls for: the measured one plus the
        surge/swab model's BHP change at the string's speed (the change that stops with the
        string), while circulating."""
        if not stop:
            self.emergency_bhp_pa = self.pressed_bhp_pa = self.emergency_dp_start_pa = float("nan")
            return self.emergency_bhp_pa
        if not np.isfinite(self.pressed_bhp_pa):
            median = self.bhp_gauge.median
            self.pressed_bhp_pa = median if np.isfinite(median) else self.last_bhp_pa
            speed = string_velocity_mps if np.isfinite(string_velocity_mps) else 0.0
            change = surge_swab_pa(self.wm, np.array([speed]), circulation_m3s)[0] \
                if circulation_m3s > 0.0 else 0.0
            self.emergency_dp_start_pa = float(max(choke_dp_pa + change, 0.0))
        held = self.well_control.target_bhp_pa if self.well_control is not None \
            else self.pressed_bhp_pa
        low, high = self.window_pa
        self.emergency_bhp_pa = float(np.clip(held, low, high))
        return self.emergency_bhp_pa

    def _answer_trip(self, trip: TripAction, guard: int, command: np.ndarray,
                     clamps: list[Notice], shut: bool) -> None:
        """A lost circulation: the choke's flow reference set (held shut) while the friction
        is made good (``shut``: the answer asks it and the choke is not on its emergency
        stop's BHP loop); the back-pressure pump at least at its flow, unless the window
        guard is relieving a BHP over the window."""
        if shut:
            command[U_CHOKE] = float(np.clip(trip.choke_flow_m3s, self.lower[U_CHOKE], self.upper[U_CHOKE]))
            clamps.append(Notice("pump_trip_response", trip.reason))
        floor = min(trip.bpp_flow_min_m3s, self.upper[U_BPP_FLOW])
        if guard <= 0 and command[U_BPP_FLOW] < floor:
            clamps.append(Notice("pump_trip_floor",
                                 f"{COMMAND_NAMES[U_BPP_FLOW]} {command[U_BPP_FLOW]:.6g} -> {floor:.6g} "
                                 f"({trip.reason}: the back-pressure pump gives the choke a "
                                 "flow)", floor))
            command[U_BPP_FLOW] = floor

    def _drive_back(self, guard: int, command: np.ndarray, surface_flows,
                    circulation_m3s: float, relief_m3s: float) -> None:
        """Choke flow reference (by ``relief_m3s``) and back-pressure pump (one slew) from
        where the machines are (the measured return and pump flows; the last commands where
        unmeasured), toward the window: more flow out and less pumped in over it (guard
        +1), the other way under it,
        unless the advisor already asks for more of that. The choke starts from the flow
        going in (back-pressure pump plus circulation) where that is further toward the
        window than the return flow: under the window it lets out less than goes in at
        once, so the annulus fills, instead of slewing down from a return flow that still
        drains it (a string come to rest, a pump winding down)."""
        measured = [float(v) for v in (surface_flows or (np.nan, np.nan))]
        now = [m if np.isfinite(m) else self.previous[i] for i, m in zip((U_CHOKE, U_BPP_FLOW), measured)]
        flowing_in = now[1] + circulation_m3s
        start = max(now[0], flowing_in) if guard > 0 else min(now[0], flowing_in)
        choke = start + guard * relief_m3s
        pump = now[1] - guard * self.slew[U_BPP_FLOW]
        command[U_CHOKE] = max(command[U_CHOKE], choke) if guard > 0 else min(command[U_CHOKE], choke)
        command[U_BPP_FLOW] = min(command[U_BPP_FLOW], pump) if guard > 0 else max(command[U_BPP_FLOW], pump)
        flows = slice(U_CHOKE, U_BPP_FLOW + 1)      # the choke flow and the back-pressure pump's
        command[flows] = np.clip(command[flows], self.lower[flows], self.upper[flows])

    def _window_guard(self, bhp_pa: float, clamps: list[Notice],
                      friction_free_bhp_pa: float = float("nan"),
                      measured: bool = True) -> int:
        """+1 while the BHP is over the fracture pressure less the margin (relieve: more
        choke flow, less back-pressure pump), -1 under the pore pressure plus the margin
        (hold back: less choke flow, more pump), else 0; the reason goes to ``clamps``.
        A BHP inside that is heading out of it within ``window_guard_lead_s`` on the BHP
        gauge's trend (``measured``: ``bhp_pa`` is the gauge's) counts as out. While
        circulation is lost the low edge is judged on the lower of the measured BHP and
        ``friction_free_bhp_pa`` (the BHP once a surge's friction is gone). The notice
        names the reading that is out, the BHP itself first, and carries its value."""
        if not (self.config.protection.window_guard and np.isfinite(bhp_pa)):
            return 0
        low, high = self.config.pressure_window_pa
        judged = min(bhp_pa, friction_free_bhp_pa) if np.isfinite(friction_free_bhp_pa) \
            else bhp_pa
        ahead = self._bhp_ahead_pa(bhp_pa) if measured else bhp_pa
        if bhp_pa > high or (judged >= low and ahead > high):
            over = True
            what, value = ("BHP", bhp_pa) if bhp_pa > high else ("BHP heading", ahead)
        elif judged < low or ahead < low:
            over = False
            what, value = ("BHP", bhp_pa) if bhp_pa < low \
                else ("BHP without friction", judged) if judged < low else ("BHP heading", ahead)
        else:
            return 0
        clamps.append(Notice("window_guard", f"{what} {value / PA_PER_BAR:.1f} bar "
                             f"{'over' if over else 'under'} the window's "
                             f"{'fracture' if over else 'pore'} limit "
                             f"{(high if over else low) / PA_PER_BAR:.1f} bar: choke flow "
                             f"reference {'up' if over else 'down'}, back-pressure pump "
                             f"{'down' if over else 'up'}", value))
        return 1 if over else -1

    def _relief_m3s(self, guard: int, bhp_pa: float, measured: bool) -> float:
        """The guard's step of the choke flow past the flows [m^3/s]: one slew, or over the
        window, if more, the flow out of the annulus that takes the BHP ahead (``bhp_pa``
        carried ``window_guard_lead_s`` ahead on the gauge's slope when ``measured``) back
        to the fracture edge less the margin over the lead: its compliance times that
        overshoot over the lead. A BHP coming back fast from under the window is not
        opened on: ahead of it the overshoot is small. Under the window it stays one slew
        (the pump-trip answer governs the choke when the BHP falls fastest)."""
        slew = float(self.slew[U_CHOKE])
        lead = self.config.protection.window_guard_lead_s
        if guard <= 0 or lead <= 0.0:
            return slew
        ahead = self._bhp_ahead_pa(bhp_pa) if measured else bhp_pa
        overshoot_pa = ahead - self.config.pressure_window_pa[1]
        return max(slew, self.annulus_compliance_m3_per_pa * overshoot_pa / lead)

    def _bhp_ahead_pa(self, bhp_pa: float) -> float:
        """``bhp_pa`` carried ``window_guard_lead_s`` ahead on the least-squares slope of the
        gauge's samples over as long; ``bhp_pa`` itself without a lead, or while the
        samples cover under nine tenths of it (a gauge just back from a gap)."""
        lead = self.config.protection.window_guard_lead_s
        trend = self.bhp_trend.samples
        if lead <= 0.0 or not trend or trend[-1][0] - trend[0][0] < 0.9 * lead:
            return bhp_pa
        slope = self.bhp_trend.slope
        return bhp_pa + slope * lead if np.isfinite(slope) else bhp_pa

    def _limit_opening(self, opening: float | None, clamps: list[Notice]) -> float | None:
        """A manual choke opening inside the choke's range [1] (None stays None)."""
        if opening is None:
            return None
        lag = self.config.actuators.choke
        limited = float(np.clip(opening, lag.minimum, lag.maximum))
        if limited != opening:
            clamps.append(Notice("machine_limit", f"choke_opening_ref {opening:.6g} -> "
                                 f"{limited:.6g} (machine range)"))
        return limited
