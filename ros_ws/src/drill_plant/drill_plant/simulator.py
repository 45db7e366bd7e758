"""Seeded truth-plant simulator: advances sensor frames, samples noisy sensors and
reports the true state (plain Python; the plant node wires it to topics)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drill_core import hydraulics as hy
from drill_core.config import RigConfig
from drill_plant.plant_model import (PlantLayout, SteadyState, build_frame_function,
                                     build_outputs_function)


class PlantDiverged(RuntimeError):
    """The integration produced a non-finite state."""


@dataclass(frozen=True)
class Measurement:
    """One noisy sensor sample (SI); string flow is NaN while the mud pump is off."""
    block_position_m: float
    choke_dp_pa: float
    bhp_pa: float
    string_flow_m3s: float
    string_flow_valid: bool


@dataclass(frozen=True)
class Truth:
    """True state and derived quantities at a sample time (SI)."""
    state: np.ndarray
    inputs: np.ndarray           # [u_b, u_c, q_bpp, p_in] held over the last plant step
    choke_flow_m3s: float
    bit_flow_m3s: float
    annulus_friction_pa: np.ndarray
    string_friction_pa: float
    ecd_kgm3: float


class PlantSimulator:
    """The stochastic wellbore + hoisting plant, one sensor frame per call."""

    def __init__(self, config: RigConfig, initial: SteadyState, seed: int):
        self.config = config
        self.wm = hy.build_well_model(config.well, config.plant.yield_regularisation_velocity_mps,
                                      config.plant.choke_regularisation_pa)
        self.layout = PlantLayout(self.wm.n)
        self._frame = build_frame_function(self.wm, config)
        self._outputs = build_outputs_function(self.wm)
        process_seed, sensor_seed = np.random.SeedSequence(seed).spawn(2)
        self._process_rng = np.random.default_rng(process_seed)
        self._sensor_rng = np.random.default_rng(sensor_seed)
        self.state = initial.state.astype(float).copy()
        self.inputs = initial.inputs.astype(float).copy()
        self.steps_per_frame = config.plant.steps_per_frame
        self._substep_s = config.plant.step_s / config.plant.substeps

    def advance(self, inputs: np.ndarray) -> None:
        """Integrate one frame with ``inputs`` [4 x steps_per_frame] held per plant step."""
        inputs = np.asarray(inputs, dtype=float)
        count = self.steps_per_frame * self.config.plant.substeps
        dw = self._process_rng.normal(0.0, np.sqrt(self._substep_s), size=(self.layout.size, count))
        states = np.asarray(self._frame(self.state, inputs, dw))
        final = states[:, -1]
        if not np.all(np.isfinite(final)):
            raise PlantDiverged(f"non-finite plant state after inputs {inputs[:, -1]}")
        self.state = final
        self.inputs = inputs[:, -1].copy()

    def measure(self, circulating: bool) -> Measurement:
        """Sensors of eq. 48 with the configured noise; no string flow while not circulating."""
        lay, noise, x = self.layout, self.config.plant.measurement_noise, self.state
        draw = self._sensor_rng.normal(size=4)
        p0 = self.config.well.choke_downstream_pressure_pa
        flow = x[lay.string_flow] + noise.string_flow_m3s * draw[3]
        return Measurement(
            block_position_m=float(x[lay.position] + noise.block_position_m * draw[0]),
            choke_dp_pa=float(x[lay.pressure(1)] - p0 + noise.choke_dp_pa * draw[1]),
            bhp_pa=float(x[lay.pressure(self.wm.n)] + noise.bhp_pa * draw[2]),
            string_flow_m3s=float(flow) if circulating else float("nan"),
            string_flow_valid=circulating)

    def truth(self) -> Truth:
        out = np.asarray(self._outputs(self.state, self.inputs)).ravel()
        n = self.wm.n
        g = self.config.well.gravity_mps2
        bhp = self.state[self.layout.pressure(n)]
        return Truth(state=self.state.copy(), inputs=self.inputs.copy(),
                     choke_flow_m3s=float(out[0]), bit_flow_m3s=float(out[1]),
                     annulus_friction_pa=out[2:2 + n - 1].copy(),
                     string_friction_pa=float(out[1 + n]),
                     ecd_kgm3=float(bhp / (g * self.wm.geometry.node_depth_m[-1])))
