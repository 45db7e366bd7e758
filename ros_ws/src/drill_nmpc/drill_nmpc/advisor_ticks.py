"""The advisors' per-sample logic as plain tick classes (no rclpy): what the ``nmpc``,
``automated_mpd`` and ``baseline`` nodes command for one sample from the inputs the node
collected for it (the setpoints to plan with come from drill_nmpc.setpoint_book, which
the caller keeps). The nodes move messages in and out of these; the in-process loop
bench (drill_studies.loop_bench) steps the same classes."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from drill_core.channel_watch import ChannelWatch
from drill_core.config import RigConfig
from drill_core.estimation_model import EstimationModel
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_PUMP_PRESSURE
from drill_core.tripping.sequence import (CONNECTION, CONNECTION_PHASES, MOVING,
                                          SET_SLIPS, pump_factor_ahead)
from drill_nmpc.automated_mpd import AutomatedMpd, EstimateView, MpdCommand
from drill_nmpc.baseline import Baseline
from drill_nmpc.inputs import choke_command, choke_input
from drill_nmpc.prediction_model import nmpc_estimation_model
from drill_nmpc.setpoint_book import adopt_applied_block, within_speed_limits
from drill_nmpc.soft_constraints import SLACK_NAMES
from drill_nmpc.solve_result import SolveResult
from drill_nmpc.supervisor import Supervisor

BASELINE_KP_M3S_PER_PA = 5.0e-9     # the PI baseline's default gains: 30 L/min per bar
BASELINE_TI_S = 5.0
BASELINE_BRAKING_MPS2 = 0.05        # a multi-stand trip: the ramp's deceleration onto a stand's end
BASELINE_FROZEN_AFTER_SAMPLES = 2   # a gauge repeating its value at the next sample is frozen
                                    # (a live gauge's noise never repeats a float)
BASELINE_GAUGES = ("block_position_m", "bhp_pa", "return_flow_m3s")
CONNECTION_BPP_FLOW_M3S = 0.01      # the advisors' back-pressure pump through a connection (600 L/min)


@dataclass
class AdvisorCommand:
    """An advisor's command to the process protection: the fields of drill_msgs/RigCommand
    an advisor sets (SI)."""
    block_position_ref_m: float
    choke_flow_ref_m3s: float        # flow reference, or the pressure loop's feedforward
    bpp_flow_m3s: float
    spp_pa: float
    mud_pump_on: bool
    choke_pressure_control: bool = False
    choke_dp_ref_pa: float = 0.0     # pressure loop: set-point at the command's stamp
    choke_dp_ref_rate_pa_s: float = 0.0


@dataclass
class SupervisorRequest(AdvisorCommand):
    """An advisor's command as it goes to the process protection: drill_msgs/RigCommand's
    fields an advisor sets (SI), with the setpoint book's BHP reference (NaN until it is
    resolved), the window it keeps to and the operator's trip-speed limit it planned under
    (the protection limits with the limit on the command, the same in every run)."""
    choke_manual: bool = False
    choke_opening_ref: float = 0.0
    bhp_ref_pa: float = math.nan
    bhp_window_low_pa: float = math.nan
    bhp_window_high_pa: float = math.nan
    trip_speed_limit_in_mps: float = math.nan
    trip_speed_limit_out_mps: float = math.nan

    @classmethod
    def of(cls, command: AdvisorCommand, book) -> "SupervisorRequest":
        """``command`` with the setpoint book ``book``'s reference, window and limit."""
        limit = float(book.active.trip_speed_limit_mps)
        low, high = book.window_pa
        return cls(**asdict(command),
                   bhp_ref_pa=float(book.active.bhp_ref_pa) if book.bhp_resolved else math.nan,
                   bhp_window_low_pa=low, bhp_window_high_pa=high,
                   trip_speed_limit_in_mps=limit, trip_speed_limit_out_mps=limit)


@dataclass(frozen=True)
class StartInputs:
    """The scenario's initial operating point as the advisors start from it (SI): the
    values the actuators and the protection start from too."""
    choke_flow_m3s: float
    choke_dp_pa: float
    bpp_flow_m3s: float
    spp_pa: float
    circulating: bool

    @classmethod
    def of(cls, initial, op) -> "StartInputs":
        """From the scenario's ``initial`` section and its operating point
        (drill_core.operating_point: the choke flow and the stand-pipe pressure)."""
        return cls(float(op.choke_flow_m3s), float(initial.choke_dp_pa),
                   float(initial.bpp_flow_m3s), float(op.inputs[U_PUMP_PRESSURE]),
                   initial.circulation_m3s > 0.0)


class NmpcTick:
    """The NMPC supervisor as the nmpc node runs it: u_{-1} at the first usable estimate
    (hold the string where it is estimated, the other inputs at the start point), the
    block reference the drawworks was given adopted, a hold on an unusable estimate, the
    hand-back to manual while the controller is disabled. On a multi-stand trip (``trip``,
    the scenario's programme) each stand's move planned to its end, and the inputs the
    rig floor has pinned over the horizon (:meth:`floor_plan`): the stand-pipe pressure
    on the floor's pump ramps and connection (the floor scales the command, which stays at
    the start's), the block reference at the estimated string while the floor has the
    string; the choke and the back-pressure pump are the NMPC's through the connection,
    the pump's input reference the conventional connection's flow through the whole trip
    (its 30 s lag is twice the horizon: kept running, it is there when the mud pump ramps
    down), and each move pays for running past its stand's end (the OCP's ``stand_end``
    rows: the floor takes a stand as arrived only with the string at rest near its end)."""

    def __init__(self, config: RigConfig, em: EstimationModel, start: StartInputs,
                 trip=None):
        self.config = config
        self.cfg = config.nmpc
        self.em = em
        self.start = start
        self.trip = trip
        self.pulled_m = 0.0 if trip is None else trip.pulled_at_start_m
        self._supervisors: dict[float, Supervisor] = {}     # per string tripped to [m]
        self.supervisor = self._supervisor_for(self.pulled_m)
        self.u_prev: np.ndarray | None = None
        self._phase: tuple | None = None        # (stand, phase) of the floor's last step
        self._phase_start_s = 0.0               # when the advisor first saw it [s]

    def _supervisor_for(self, pulled_m: float) -> Supervisor:
        """The supervisor of the string ``pulled_m`` short (built once per length)."""
        if pulled_m not in self._supervisors:
            em = self.em if pulled_m == 0.0 else nmpc_estimation_model(self.config,
                                                                        pulled_m=pulled_m)
            self._supervisors[pulled_m] = Supervisor(self.config, em,
                                                     floor_trip=self.trip is not None)
        return self._supervisors[pulled_m]

    @property
    def fallback_count(self) -> int:
        """Fallbacks of the run, over every string length's supervisor."""
        return sum(s.fallback_count for s in self._supervisors.values())

    @property
    def rollouts(self) -> int:
        return sum(s.rollouts for s in self._supervisors.values())

    def step(self, x: np.ndarray | None, setpoints, actuators: dict, floor=None,
             time_s: float = 0.0) -> SolveResult | None:
        """One sample: ``x`` the estimate in the model's layout (None: unusable, the last
        input held; None returned when there is none yet), ``setpoints`` the ones to plan
        with, ``actuators`` the measured actuator outputs (drill_nmpc.supervisor); on a
        multi-stand trip ``floor`` the rig floor's command at the sample, at ``time_s``."""
        if x is None:
            if self.u_prev is None:
                return None
            result = self.supervisor.hold(self.u_prev, "invalid_estimate")
        else:
            if self.u_prev is None:
                self.u_prev = self._initial_input(x)
            self.u_prev = adopt_applied_block(self.u_prev, actuators.get("block_reference_m"))
            fixed, bpp_ref = None, 0.0
            if floor is not None:     # the back-pressure pump kept running through the trip
                setpoints, fixed = self.floor_plan(x, setpoints, floor, time_s)
                bpp_ref = CONNECTION_BPP_FLOW_M3S
                if floor.step.phase != MOVING:      # the floor drives the block: the model's
                    actuators = {k: v for k, v in actuators.items()   # hangs the string on it
                                 if not k.startswith("block")}
            result = self.supervisor.step(x, setpoints, self.u_prev, actuators=actuators,
                                          fixed_inputs=fixed, bpp_reference_m3s=bpp_ref) \
                if setpoints.controller_enabled else self._manual(x)
        self.u_prev = result.u
        return result

    def floor_plan(self, x: np.ndarray, setpoints, floor, time_s: float):
        """The setpoints and pinned inputs (N_c x 4, NaN: free) of a multi-stand trip's
        sample: the stand's end as the block target while it moves; the stand-pipe pressure
        over the horizon at the start's times the floor's pump share, the pump planned on
        only above ``floor_pump_on_share`` of its rate (below, the bit's flow has stopped
        going down and not started coming up: the annulus' back-pressure and the gelled
        mud hold it, which the prediction's friction laws do not); while the floor has
        the string the block at the estimated string; the back-pressure pump at the
        conventional connection's flow while the slips are set. A stand racked (or made up)
        since the last sample: the supervisor of the new string's model, planning again from
        the estimate in the string's new frame."""
        position_m = float(x[self.em.position])
        step = floor.step
        pulled_m = step.stands_pulled * self.trip.stand_length_m
        if pulled_m != self.pulled_m:
            self.pulled_m = pulled_m
            self.supervisor = self._supervisor_for(pulled_m)
            self.supervisor.reset()
            self.u_prev[U_BLOCK] = position_m
        if (step.stand, step.phase) != self._phase:
            self._phase, self._phase_start_s = (step.stand, step.phase), time_s
        elapsed_s, ts = time_s - self._phase_start_s, self.supervisor.problem.ts
        fixed = np.full((self.supervisor.problem.Nc, 4), np.nan)
        fixed[:, U_PUMP_PRESSURE] = [
            self.start.spp_pa * pump_factor_ahead(self.trip, step.phase, elapsed_s,
                                                  (k + 0.5) * ts)
            for k in range(fixed.shape[0])]
        held = step.phase != MOVING
        if held:
            fixed[:, U_BLOCK] = position_m
        if step.phase == SET_SLIPS:         # the back-pressure pump's lag passed before the
            fixed[:, U_BPP_FLOW] = CONNECTION_BPP_FLOW_M3S   # mud pump ramps down
        target = floor.advisor_target_m(position_m, self.trip.stand_length_m)
        setpoints = replace(setpoints, block_position_target_m=target,
                            mud_pump_on=bool(step.pump_factor > self.cfg.floor_pump_on_share))
        return setpoints, fixed

    def command(self, result: SolveResult, mud_pump_on: bool) -> AdvisorCommand:
        """The command for ``result``: the choke's part per its loop (drill_nmpc.inputs);
        on a multi-stand trip the stand-pipe pressure the start's (the floor scales it)."""
        u = np.asarray(result.u, dtype=float)
        choke = choke_command(self.cfg, result, self.start.choke_flow_m3s)
        spp_pa = self.start.spp_pa if self.trip is not None else float(u[U_PUMP_PRESSURE])
        return AdvisorCommand(float(u[U_BLOCK]), choke.flow_m3s, float(u[U_BPP_FLOW]),
                              spp_pa, bool(mud_pump_on), choke.pressure_control,
                              choke.dp_ref_pa, choke.dp_ref_rate_pa_s)

    def _initial_input(self, x) -> np.ndarray:
        s = self.start
        u = np.array([x[self.em.position], choke_input(self.cfg, s.choke_flow_m3s, s.choke_dp_pa),
                      s.bpp_flow_m3s, s.spp_pa])
        return self.supervisor.safe_input(u)

    def _manual(self, x) -> SolveResult:
        """Hand-back to manual: hold the string where it is, the other inputs as they were."""
        sup = self.supervisor
        sup.reset()
        u = self.u_prev.copy()
        u[U_BLOCK] = float(np.clip(x[self.em.position], sup.u_min[U_BLOCK], sup.u_max[U_BLOCK]))
        u = np.where(np.isfinite(u), u, self.u_prev)
        return SolveResult(u=u, success=False, fallback="none", status="manual", iterations=0,
                           solve_time_s=0.0, cost=float("nan"),
                           slacks={n: float("nan") for n in SLACK_NAMES},
                           planned_inputs=np.tile(u, (sup.problem.N, 1)),
                           configuration=sup.configuration, choke_flow_m3s=sup.choke_flow_m3s)


class AutomatedMpdTick:
    """Automated MPD as its node runs it: the last command held while the estimate is not
    finite or the BHP reference not resolved, the block reference at the estimated string
    until a trip profile starts. On a multi-stand trip (``trip``, the scenario's programme)
    the managed-pressure connection: each stand's move planned to its end, and the
    back-pressure pump at CONNECTION_BPP_FLOW_M3S while the floor has the string (from the
    slips' setting, so that the pump's lag has passed before the mud pump ramps down), the
    choke's set-point holding the BHP reference on the friction the estimate has left
    (drill_nmpc.automated_mpd: ``string_held``, ``mud_at_rest``)."""

    def __init__(self, config: RigConfig, em: EstimationModel, start: StartInputs, trip=None):
        self.controller = AutomatedMpd(config, em, start.bpp_flow_m3s, start.spp_pa)
        self.held = AdvisorCommand(0.0, start.choke_flow_m3s, start.bpp_flow_m3s, start.spp_pa,
                                   start.circulating)
        self.start = start
        self.stand_length_m = math.nan if trip is None else trip.stand_length_m
        self.gauges = ChannelWatch(BASELINE_GAUGES, BASELINE_FROZEN_AFTER_SAMPLES)

    def step(self, view: EstimateView, setpoints, bhp_resolved: bool,
             speed_limits_mps: tuple[float, float], applied_block_m: float,
             floor=None) -> tuple[AdvisorCommand, MpdCommand | None]:
        """The command for one sample and the controller's output (None: the last command
        held, the estimate not finite or the BHP reference not resolved). On a multi-stand
        trip ``floor`` is the rig floor's command at the sample
        (drill_core.tripping.rig_floor): the profile goes to the stand's end while it
        moves and stays on the estimated string while the floor has it."""
        if floor is not None:
            setpoints = replace(setpoints, block_position_target_m=(
                floor.advisor_target_m(view.string_position_m, self.stand_length_m)))
            held = floor.step.phase != MOVING
            if held:
                applied_block_m = view.string_position_m
            self.controller.string_held = held
            self.controller.mud_at_rest = floor.step.phase == CONNECTION
            self.controller.bpp = CONNECTION_BPP_FLOW_M3S if held else self.start.bpp_flow_m3s
        if self.controller.profile is None and math.isfinite(view.string_position_m):
            self.held.block_position_ref_m = view.string_position_m
        if not bhp_resolved or not all(math.isfinite(v) for v in
                                       (view.bhp_pa, view.string_position_m)):
            return self.held, None
        self.controller.adopt_applied(applied_block_m)
        c = self.controller.step(view, within_speed_limits(setpoints, speed_limits_mps,
                                                           view.string_position_m),
                                 setpoints.bhp_ref_pa)
        self.held = AdvisorCommand(c.block_position_ref_m, c.choke_flow_feedforward_m3s,
                                   c.bpp_flow_m3s, c.spp_pa, bool(setpoints.mud_pump_on), True,
                                   c.choke_dp_ref_pa, c.choke_dp_ref_rate_pa_s)
        return self.held, c


class BaselineTick:
    """The PI baseline as its node runs it: a fixed-speed block ramp and the PI choke on
    the measured BHP (its reference once resolved), the bpp and the stand-pipe pressure
    at the start point. On a multi-stand trip (``trip``, the scenario's programme) the
    conventional connection: the ramp slows onto each stand's end, and the back-pressure
    pump runs at CONNECTION_BPP_FLOW_M3S while the mud pump is under its rate, giving
    the PI choke a flow to hold BHP with. Its gauges are screened (drill_core.channel_watch):
    a frozen one reads as a dropout, so the PI holds instead of winding up on it."""

    def __init__(self, config: RigConfig, trip_speed_mps: float, start: StartInputs,
                 kp_m3s_per_pa: float = BASELINE_KP_M3S_PER_PA, ti_s: float = BASELINE_TI_S,
                 trip=None):
        self.controller = Baseline(start.choke_flow_m3s, kp_m3s_per_pa, ti_s,
                                   config.nmpc.input_max.choke_flow_m3s, trip_speed_mps,
                                   config.nmpc.sample_time_s,
                                   math.inf if trip is None else BASELINE_BRAKING_MPS2)
        self.start = start
        self.stand_length_m = math.nan if trip is None else trip.stand_length_m
        self.gauges = ChannelWatch(BASELINE_GAUGES, BASELINE_FROZEN_AFTER_SAMPLES)

    def step(self, position_m: float, bhp_pa: float, setpoints, bhp_resolved: bool,
             applied_block_m: float, return_flow_m3s: float = math.nan, floor=None
             ) -> tuple[AdvisorCommand, bool]:
        """The command for one sample from the measured block position [m], BHP [Pa] and
        return flow [m^3/s], and False when the BHP was not finite (the choke reference
        held). On a multi-stand trip ``floor`` is the rig floor's command at the sample
        (drill_core.tripping.rig_floor): the ramp goes to the stand's end while it moves
        and waits at the string while the floor has it (the slips, a connection)."""
        screened, _ = self.gauges.screen(0.0, [position_m, bhp_pa, return_flow_m3s])
        position_m, bhp_pa, return_flow_m3s = (float(v) for v in screened)
        c = self.controller
        c.adopt_applied(applied_block_m)
        target_m = setpoints.block_position_target_m
        bpp_m3s = self.start.bpp_flow_m3s
        if floor is not None:
            target_m = floor.advisor_target_m(position_m, self.stand_length_m)
            if floor.step.phase != MOVING and math.isfinite(position_m):
                c.block_ref_m = position_m
            if floor.step.phase in CONNECTION_PHASES:
                bpp_m3s = CONNECTION_BPP_FLOW_M3S
        ok = c.step(position_m, bhp_pa, target_m,
                    setpoints.bhp_ref_pa if bhp_resolved else None, setpoints.controller_enabled,
                    return_flow_m3s)
        return AdvisorCommand(float(c.block_ref_m), float(c.choke_ref_m3s), bpp_m3s,
                              self.start.spp_pa, bool(setpoints.mud_pump_on)), ok
