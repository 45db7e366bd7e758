"""The phases of a multi-stand trip, stand after stand: a tick class fed the bit's height,
the string's velocity and the line tension, handing out what the rig floor does (slips,
elevator, pump rate, the bit height wanted, the stands off the string).

Pulling out, each stand is: pick up (the line takes the string's weight, then the slips
are pulled), move (the stand's length up, the speed is the controller's), set the slips
(at rest; the block slacks off and the elevator is unlatched), ramp the pump down, break
out and rack back the stand (the connection), ramp the pump up. Running in starts at the
connection (make up the stand), then ramps, picks up, moves down and sets the slips. The
string is a stand shorter (out) or longer (in) from the end of the connection, when the
elevator is latched to its new top: the string has not moved, so its position counts
from a frame a stand away (:func:`position_after_connection`).
"""
from __future__ import annotations

from dataclasses import dataclass

from drill_core.tripping.programme import TripProgramme

PICK_UP, MOVING, SET_SLIPS, PUMP_DOWN, CONNECTION, PUMP_UP, DONE = (
    "pick_up", "moving", "set_slips", "pump_down", "connection", "pump_up", "done")
STAND_PHASES = {
    "out": (PICK_UP, MOVING, SET_SLIPS, PUMP_DOWN, CONNECTION, PUMP_UP),
    "in": (PUMP_DOWN, CONNECTION, PUMP_UP, PICK_UP, MOVING, SET_SLIPS),
}
IN_SLIPS = frozenset({SET_SLIPS, PUMP_DOWN, CONNECTION, PUMP_UP, DONE})
CONNECTION_PHASES = (PUMP_DOWN, CONNECTION, PUMP_UP)   # the mud pump under its rate
ARRIVAL_TOLERANCE_M = 0.5        # the stand's move counts as done this close (the stick-up the
                                 # floor works at; a trip leg's, drill_analysis.report) ...
AT_REST_MPS = 0.01               # ... with the string this slow
SLACK_N = 1.0e3                  # the elevator is unlatched once the line carries less


@dataclass(frozen=True)
class TripStep:
    """What the rig floor does after one tick."""
    phase: str
    stand: int                 # the stand in hand, 1-based (the last one once done)
    slips_set: bool
    latched: bool              # the elevator holds the string
    pump_factor: float         # the mud pump's share of its rate, 0..1
    bit_height_target_m: float  # where the stand's move takes the bit over the BHP node [m]
    stands_pulled: int         # stands off the string against the configured one


class StandSequencer:
    """Walks the programme's stands through their phases; ``step`` once per tick."""

    def __init__(self, programme: TripProgramme, buoyed_weight_n: float, start_time_s: float,
                 stands_pulled: int = 0):
        self.programme = programme
        self.weight_n = buoyed_weight_n
        self.phases = STAND_PHASES[programme.direction]
        self.sign = 1 if programme.direction == "out" else -1
        self.stand = 1
        self.index = 0
        self.phase_start_s = start_time_s
        self.stands_pulled = stands_pulled
        self.latched = programme.direction == "out"

    @property
    def phase(self) -> str:
        return DONE if self.stand > self.programme.stands else self.phases[self.index]

    @property
    def bit_height_target_m(self) -> float:
        """The bit's height over the BHP node at the end of this stand's move [m]."""
        ahead = 1 if self.programme.direction == "out" else 0
        return (self.stands_pulled + ahead) * self.programme.stand_length_m

    def _finished(self, time_s: float, bit_height_m: float, velocity_mps: float,
                  line_tension_n: float, block_ready: bool) -> bool:
        p, elapsed = self.programme, time_s - self.phase_start_s
        phase = self.phase
        if phase == PICK_UP:
            return line_tension_n >= self.weight_n - p.pickup_margin_n
        if phase == MOVING:
            return (abs(bit_height_m - self.bit_height_target_m) <= ARRIVAL_TOLERANCE_M
                    and abs(velocity_mps) <= AT_REST_MPS)
        if phase == SET_SLIPS:
            return line_tension_n <= SLACK_N
        if phase == CONNECTION and not block_ready:
            return False
        duration = {PUMP_DOWN: p.pump_ramp_down_s, CONNECTION: p.connection_s,
                    PUMP_UP: p.pump_ramp_up_s}[phase]
        return elapsed >= duration

    def _advance(self, time_s: float) -> None:
        phase = self.phase
        if phase == SET_SLIPS:
            self.latched = False
        elif phase == CONNECTION:
            self.stands_pulled += self.sign
            self.latched = True
        self.phase_start_s = time_s
        self.index += 1
        if self.index == len(self.phases):
            self.index = 0
            self.stand += 1

    def _pump_factor(self, time_s: float) -> float:
        return pump_factor(self.programme, self.phase, time_s - self.phase_start_s)

    def step(self, time_s: float, bit_height_m: float, velocity_mps: float,
             line_tension_n: float, block_ready: bool = True) -> TripStep:
        """Advance on the tick's measurements: ``bit_height_m`` the bit's height over the
        BHP node (stands pulled plus the string's position) [m], ``velocity_mps`` (+ up)
        [m/s], ``line_tension_n`` what the elevator carries [N]; ``block_ready``: the block
        is at the new top of the string, so a connection may end (the elevator latches
        there and nowhere else)."""
        if self.phase != DONE and self._finished(time_s, bit_height_m, velocity_mps,
                                                 line_tension_n, block_ready):
            self._advance(time_s)
        phase = self.phase
        return TripStep(phase=phase, stand=min(self.stand, self.programme.stands),
                        slips_set=phase in IN_SLIPS or phase == PICK_UP, latched=self.latched,
                        pump_factor=self._pump_factor(time_s),
                        bit_height_target_m=self.bit_height_target_m,
                        stands_pulled=self.stands_pulled)


def pump_factor(programme: TripProgramme, phase: str, elapsed_s: float) -> float:
    """The mud pump's share of its rate ``elapsed_s`` into ``phase``."""
    p = programme
    if phase == PUMP_DOWN:
        left = max(0.0, 1.0 - elapsed_s / p.pump_ramp_down_s) if p.pump_ramp_down_s > 0 else 0.0
        if p.pump_stop_share is None or left == 0.0:
            return left
        return p.pump_stop_share + (1.0 - p.pump_stop_share) * left * left
    if phase == CONNECTION:
        return 0.0
    if phase == PUMP_UP:
        return min(1.0, elapsed_s / p.pump_ramp_up_s) if p.pump_ramp_up_s > 0 else 1.0
    return 1.0


def pump_factor_ahead(programme: TripProgramme, phase: str, elapsed_s: float,
                      ahead_s: float) -> float:
    """The pump's share of its rate ``ahead_s`` from now, ``elapsed_s`` into ``phase``: the
    ramps and the connection taken to last their programmed time, a phase of no set time
    (pick-up, move, setting the slips) to last beyond ``ahead_s``."""
    phases = STAND_PHASES[programme.direction]
    t = elapsed_s + ahead_s
    durations = {PUMP_DOWN: programme.pump_ramp_down_s, CONNECTION: programme.connection_s,
                 PUMP_UP: programme.pump_ramp_up_s}
    while phase in durations and t >= durations[phase]:
        t -= durations[phase]
        phase = phases[(phases.index(phase) + 1) % len(phases)]
    return pump_factor(programme, phase, t)


def position_after_connection(position_m: float, pulled_before_m: float,
                              pulled_after_m: float) -> float:
    """The string's position x_s [m] in the frame of the new string, the bit where it was:
    h_bit + x_s is the same before and after (h_bit: the length pulled, drill_core.well)."""
    return position_m + pulled_before_m - pulled_after_m
