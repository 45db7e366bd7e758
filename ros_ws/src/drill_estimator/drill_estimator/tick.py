"""One sample of the rig's estimator (plain Python): the channels screened
(drill_core.channel_watch: a frozen channel is left out like a NaN one), the UKF's time
update over the actuator frames since the last sample (drill_estimator.model_inputs), then
the update with the measurement (the string-flow channel only while the meter reads). The
first sample with finite readings initialises the filter. The estimator node and the
in-process loop bench both run it.

On a multi-stand trip the rig floor says two things the model must follow: while the
slips hold the string the block moves free, so the time update holds each sigma point's
string at rest where it is (``RigUkf.predict_frame(..., held=True)``) instead of driving it
with the drawworks' output (the held input is a virtual block that holds the estimated
string at rest on the line, ``ModelInputs.holding_block_m``); and at a connection
the string is a stand shorter or longer, so the model becomes the new string's and the
estimate's position counts from its new top (``rack``).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from drill_core.channel_watch import ChannelWatch
from drill_core.config import RigConfig
from drill_core.estimation_model import MEASUREMENT_NAMES, build_estimation_model
from drill_core.tripping.sequence import position_after_connection
from drill_estimator.model_inputs import ModelInputs
from drill_estimator.ukf import RigUkf, UpdateResult


@dataclass(frozen=True)
class _Frame:
    """An actuator frame's two fields the inputs read."""
    output: np.ndarray
    reference: float


@dataclass(frozen=True)
class TickResult:
    """What one sample did: the update (None: nothing fused - the filter initialised now,
    or could not be), the problems met, the channels found frozen."""
    update: UpdateResult | None
    problems: tuple[str, ...]
    frozen: tuple[str, ...]


class EstimatorTick:
    """The UKF with its channel screen and input history, one sample at a time."""

    def __init__(self, config: RigConfig, pulled_m: float = 0.0):
        """The estimator of the string ``pulled_m`` short of the configured one (a run-in
        trip's start, drill_core.scenario.Scenario.pulled_at_start_m): that string's model
        with the configured string's tuning and scaling, as after any connection
        (``RigUkf.use_model``)."""
        self.config = config
        self.ukf = RigUkf(config)
        if pulled_m:
            self.ukf.use_model(build_estimation_model(config, self.ukf.em.with_disturbance,
                                                      pulled_m=pulled_m))
        self.watch = ChannelWatch(MEASUREMENT_NAMES, config.estimator.frozen_after_samples)
        self.inputs = ModelInputs(self.ukf.em, self.ukf.block_input,
                                  config.estimator.frozen_after_samples,
                                  config.plant.sensor_period_s
                                  / config.estimator.valve_law_calibration_s)

    def rack(self, pulled_before_m: float, pulled_after_m: float) -> None:
        """A connection has tripped the string from ``pulled_before_m`` to
        ``pulled_after_m`` [m] pulled: the model is the new string's from the next frame
        on, and the position counts from its top."""
        shift_m = position_after_connection(0.0, pulled_before_m, pulled_after_m)
        if self.ukf.initialised:
            self.ukf.recount_position(shift_m)
        self.inputs.held[0] += shift_m
        em = build_estimation_model(self.config, self.ukf.em.with_disturbance,
                                    pulled_m=pulled_after_m)
        self.ukf.use_model(em)
        self.inputs.em = em

    def _string_held(self, frames: Mapping[str, object], steps: int) -> dict:
        """The frames with the drawworks' replaced by the virtual block: the estimated
        string at rest on the line."""
        block_m = self.inputs.holding_block_m(float(self.ukf.mean[self.ukf.em.position]))
        virtual = _Frame(np.full(steps, block_m), block_m)
        return {**frames, "drawworks": virtual}

    def step(self, time_s: float, m, frames: Mapping[str, object], steps: int,
             string_held: bool = False, pump_stopped_by_floor: bool = False) -> TickResult:
        """Take the measurement ``m`` (drill_msgs/RigMeasurement fields) at ``time_s`` after
        ``steps`` plant steps driven by ``frames`` (actuator name -> its frame: ``output``
        samples and ``reference``; absent when it did not come); ``string_held``: the slips
        held the string over those steps (the block free); ``pump_stopped_by_floor``: the
        rig floor had the mud pump stopped for a connection (the valve law takes the choke
        flow calibrated on the return-flow meter, :meth:`ModelInputs.frame`)."""
        circulating = bool(m.string_flow_valid)
        y, frozen = self.watch.screen(time_s, [
            m.block_position_m, m.choke_dp_pa, m.bhp_pa,
            m.string_flow_m3s if circulating else math.nan])
        ukf = self.ukf
        if not ukf.initialised:
            if not np.all(np.isfinite(y[:3])) or (circulating and not np.isfinite(y[3])):
                ukf.rejected += 1
                return TickResult(None, (f"cannot initialise from a non-finite measurement "
                                         f"{y.tolist()}",), frozen)
            x0 = ukf.initial_state(y, circulating)
            ukf.initialise(x0)
            self.inputs.start(x0, float(y[1]))
            self.inputs.observe_return_flow(time_s, m.return_flow_m3s, circulating)
            return TickResult(None, (), frozen)
        if string_held:
            frames = self._string_held(frames, steps)
        inputs, problems = self.inputs.frame(frames, steps, calibrated=pump_stopped_by_floor)
        try:
            ukf.predict_frame(inputs, string_held)
        except ValueError as err:          # non-finite input slipped through: skip the frame
            problems.append(f"time update skipped: {err}")
        result = ukf.update(y, circulating)
        if result.accepted and np.isfinite(y[1]):
            self.inputs.accept_choke_dp(float(y[1]))
        self.inputs.observe_return_flow(time_s, m.return_flow_m3s, circulating)
        if not result.accepted:
            problems.append(f"measurement at {time_s:.3f} s rejected: {y.tolist()}")
        elif result.dropped:
            problems.append(f"measurement at {time_s:.3f} s: {', '.join(result.dropped)} not "
                            "finite, left out of the update")
        return TickResult(result, tuple(problems), frozen)
