"""The UKF's time-update inputs u = [u_b (or u_r) m, q_c m^3/s, q_bpp m^3/s, p_in Pa] per
plant step, from the actuators' frames.

The choke flow is the Coriolis return-flow meter's last good sample on the choke line, held
over the frame, while the well circulates; while that sample is NaN, inf or frozen, or the
string-flow meter reads no circulation, a virtual flow meter takes it from the valve law
with the choke opening and the last accepted measured choke differential pressure (a
plugging choke deceives the valve law: it passes less than the law says). While the rig
floor has the mud pump stopped for a connection the valve law is calibrated: times the
meter's flow over the law's, low-passed over the frames the meter was the input (a choke
a few per cent off its data sheet). A missing or bad frame holds its actuator's last good
value, and says so.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from drill_core import hydraulics as hy
from drill_core.channel_watch import ChannelWatch
from drill_core.estimation_model import EstimationModel
from drill_core.events import ACTUATORS
from drill_core.input_layout import U_CHOKE

BLOCK_INPUTS = ("reference", "block_position")
CALIBRATION_FLOW_M3S = 1.0e-3     # the valve law is calibrated on frames it passes this (60 L/min)


def choke_flow_input(wm: hy.WellModel, choke_opening, choke_dp_pa,
                     return_flow_m3s: float) -> np.ndarray:
    """The model's choke flow [m^3/s]: the screened return-flow sample where it is finite,
    else the valve law at ``choke_opening`` and ``choke_dp_pa``."""
    if math.isfinite(return_flow_m3s):
        return np.full(np.shape(np.atleast_1d(choke_opening)), return_flow_m3s)
    return hy.choke_flow(wm, choke_opening, choke_dp_pa)


def frame_inputs(wm: hy.WellModel, block_m, choke_opening, bpp_flow_m3s, pump_pressure_pa,
                 choke_dp_pa, return_flow_m3s: float = math.nan) -> np.ndarray:
    """Filter inputs U [4 x N] for one sensor frame from the actuator outputs.

    ``block_m`` is the drawworks output u_b (or its reference u_r, per block_input). Every
    argument but the (held) return-flow sample may be a scalar (held over the frame) or N
    samples.
    """
    cols = [np.atleast_1d(np.asarray(v, dtype=float)) for v in
            (block_m, choke_opening, bpp_flow_m3s, pump_pressure_pa, choke_dp_pa)]
    steps = max(c.size for c in cols)
    cols = [np.broadcast_to(c, (steps,)) if c.size == 1 else c for c in cols]
    ref, opening, bpp, pump, dp = cols
    return np.vstack([ref, choke_flow_input(wm, opening, dp, return_flow_m3s), bpp, pump])


def holding_block(em: EstimationModel, block_input: str, position_m):
    """The block input [m] that holds the model's string at rest at ``position_m`` (a
    number or a CasADi expression): the drawworks output carrying its weight (position plus
    the static stretch), or with block_input "reference" the reference the model's block
    controller holds it on (the position)."""
    stretch = em.wm.geometry.static_stretch_m
    return position_m + (stretch if block_input == "block_position" else 0.0)


class ModelInputs:
    """Turns each frame's actuator samples into the model's inputs, holding the last good
    sample of each actuator (drawworks, choke opening, back-pressure pump flow, mud-pump
    pressure: topics.ACTUATORS order), the last accepted choke dp and the last return-flow
    sample (NaN while the meter's sample is bad or frozen)."""

    def __init__(self, em: EstimationModel, block_input: str, frozen_after_samples: int,
                 calibration_gain: float = 0.0):
        """``calibration_gain``: the weight of each frame's meter-over-law ratio in the
        valve law's calibration (the frame over the calibration's time constant; 0: the
        law uncalibrated)."""
        if block_input not in BLOCK_INPUTS:
            raise ValueError(f"block_input must be one of {BLOCK_INPUTS}, got {block_input!r}")
        self.em, self.block_input = em, block_input
        self.held = np.zeros(len(ACTUATORS))
        self.choke_dp_pa = 0.0
        self.return_flow_m3s = math.nan
        self.flow_watch = ChannelWatch(("return_flow_m3s",), frozen_after_samples)
        self.valve_law_frames = 0     # frames whose choke flow came from the valve law
        self.calibration_gain = min(1.0, calibration_gain)
        self.valve_law_factor = 1.0   # the meter's flow over the valve law's, low-passed

    def holding_block_m(self, position_m: float) -> float:
        """The block input [m] that holds the model's string at rest at ``position_m``
        (:func:`holding_block`)."""
        return holding_block(self.em, self.block_input, position_m)

    def start(self, x0: np.ndarray, choke_dp_pa: float) -> None:
        """Hold the inputs that keep the estimation model's steady state ``x0``."""
        em, wm = self.em, self.em.wm
        g, w = wm.geometry, wm.well
        self.choke_dp_pa = float(choke_dp_pa)
        block = self.holding_block_m(x0[em.position])
        flow = x0[em.string_flow]
        per_opening = float(hy.choke_flow(wm, 1.0, self.choke_dp_pa))
        opening = min(1.0, flow / per_opening) if flow > 0.0 and per_opening > 0.0 else 0.0
        rho_g = (w.mud.density_kgm3 + em.density_offset_of(x0)) * w.gravity_mps2
        pump = 0.0
        if flow > 0.0:
            pump = x0[em.string_pressure] - rho_g * (g.bit_depth_m - x0[em.position]) \
                + em.string_friction_of(x0) * float(hy.string_friction(np, wm, flow, 0.0))
        self.held = np.array([block, opening, 0.0, pump])

    def accept_choke_dp(self, choke_dp_pa: float) -> None:
        """A measured choke dp the update accepted: the virtual flow meter's from now on."""
        self.choke_dp_pa = float(choke_dp_pa)

    def observe_return_flow(self, time_s: float, return_flow_m3s: float,
                            circulating: bool) -> None:
        """A return-flow sample: the choke flow of the next frame, unless NaN, inf or
        frozen, or the string-flow meter reads no circulation (then the valve law's: with
        the mud pump tripped the meter's input put a pump-trip run 11 s over the fracture
        pressure, docs/faults.md)."""
        screened, _ = self.flow_watch.screen(time_s, [return_flow_m3s])
        self.return_flow_m3s = float(screened[0]) if circulating else math.nan

    def frame(self, frames: Mapping[str, object], steps: int,
              calibrated: bool = False) -> tuple[np.ndarray, list[str]]:
        """Inputs [4 x steps] from ``frames`` (actuator name -> its frame, with ``output``
        samples and the ``reference``; absent when it did not come) and the problems met;
        ``calibrated``: a valve-law frame takes the calibrated law (the rig floor has the
        mud pump stopped for a connection)."""
        rows, problems = [], []
        for i, name in enumerate(ACTUATORS):
            frame = frames.get(name)
            samples = None
            if frame is not None:
                if name == "drawworks" and self.block_input == "reference":
                    samples = np.full(max(len(frame.output), 1), float(frame.reference))
                else:
                    samples = np.asarray(frame.output, dtype=float)
                if samples.size == 0 or not np.all(np.isfinite(samples)):
                    problems.append(f"{name}: bad frame ({samples.size} samples); holding input")
                    samples = None
            if samples is None:
                samples = np.array([self.held[i]])
            row = samples[np.minimum(np.arange(steps), samples.size - 1)]   # hold the last
            self.held[i] = row[-1]
            rows.append(row)
        inputs = np.vstack(rows)
        law = hy.choke_flow(self.em.wm, inputs[U_CHOKE], self.choke_dp_pa)
        if math.isfinite(self.return_flow_m3s):
            self._calibrate(self.return_flow_m3s, float(np.mean(law)))
            inputs[U_CHOKE] = self.return_flow_m3s
        else:
            self.valve_law_frames += 1
            inputs[U_CHOKE] = law * (self.valve_law_factor if calibrated else 1.0)
        return inputs, problems

    def _calibrate(self, meter_m3s: float, law_m3s: float) -> None:
        """One frame's meter flow over the law's into the calibration, while the law has a
        flow to compare (at least CALIBRATION_FLOW_M3S)."""
        if law_m3s >= CALIBRATION_FLOW_M3S:
            self.valve_law_factor += self.calibration_gain * (meter_m3s / law_m3s
                                                              - self.valve_law_factor)
