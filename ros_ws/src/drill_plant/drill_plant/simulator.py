"""Seeded truth-plant simulator: advances sensor frames, samples noisy sensors and
reports the true state (plain Python; the plant node wires it to topics)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drill_core import hydraulics as hy
from drill_core.compiled import compiled
from drill_core.config import RigConfig
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW
from drill_core.tripping.sequence import position_after_connection
from drill_core.well import equivalent_density_kgm3
from drill_plant.plant_model import (PARAMETER_NAMES, PlantLayout, SteadyState,
                                     build_frame_function, build_outputs_function,
                                     held_parameters, nominal_parameters, wiener_increments)


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
    return_flow_m3s: float       # Coriolis meter on the choke line
    pit_volume_m3: float         # active pit
    bpp_flow_m3s: float          # back-pressure pump stroke counter
    hook_load_n: float           # deadline load cell: the block and the elevator's pull
    trip_tank_volume_m3: float   # trip tank level sensor


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
    influx_m3s: float            # from the formation below pore pressure
    loss_m3s: float              # into the formation above fracture pressure
    pit_gain_m3: float           # the mud the tanks (active pit, trip tank) gained since the start
    influx_volume_m3: float
    loss_volume_m3: float
    parameters: np.ndarray       # PARAMETER_NAMES in force


class PlantSimulator:
    """The stochastic wellbore + hoisting plant, one sensor frame per call."""

    def __init__(self, config: RigConfig, initial: SteadyState, seed: int,
                 pulled_m: float = 0.0):
        """The plant at ``initial`` (a steady state of the string ``pulled_m`` short of the
        configured one), its noise seeded by ``seed``."""
        self.config = config
        self._build(pulled_m)
        self.layout = PlantLayout(self.wm.n)
        self._sensors = self.layout.sensor_map(self.config.well.choke_downstream_pressure_pa)
        # the surface-flow sensors draw from their own stream so the paper's four sensors
        # (and runs recorded before the surface sensors existed) keep their noise
        # (the rig floor's sensors draw from a fourth, which leaves the first three as they were)
        process_seed, sensor_seed, surface_seed, floor_seed = \
            np.random.SeedSequence(seed).spawn(4)
        self._process_rng = np.random.default_rng(process_seed)
        self._sensor_rng = np.random.default_rng(sensor_seed)
        self._surface_rng = np.random.default_rng(surface_seed)
        self._floor_rng = np.random.default_rng(floor_seed)
        self.trip_tank_lined_up = False
        self._gain_in_trip_tank_m3 = 0.0    # the pit-gain state's part that went to the trip tank
        self.parameters = nominal_parameters(config.well)
        self._algebraic_now: np.ndarray | None = None   # build_outputs_function at the state
        self.state = initial.state.astype(float).copy()
        self.inputs = initial.inputs.astype(float).copy()
        self.steps_per_frame = config.plant.steps_per_frame
        self._substep_s = config.plant.step_s / config.plant.substeps

    def _build(self, pulled_m: float) -> None:
        """The well model and the frame and outputs functions of the string ``pulled_m``
        short (compiled when the configuration asks, cached per geometry)."""
        plant = self.config.plant
        self.wm = hy.rig_well_model(self.config, pulled_m)
        self._frame = build_frame_function(self.wm, self.config)
        self._outputs = build_outputs_function(self.wm)
        if plant.jit:
            built = compiled([self._frame, self._outputs], "plant")
            self._frame, self._outputs = built[self._frame.name()], built[self._outputs.name()]

    def rack_string(self, pulled_m: float) -> None:
        """The string tripped to ``pulled_m`` at a connection (a stand racked back or made
        up, the string in the slips): the new string's model from the next frame on, the
        string's position counted in its new frame with the bit where it was, every other
        state carried over (the nodes do not move). The block input is the caller's."""
        before = self.wm.geometry.bit_above_bhp_node_m
        self._build(pulled_m)
        position = self.layout.position
        self.state[position] = position_after_connection(self.state[position], before, pulled_m)
        self._algebraic_now = None

    def advance(self, inputs: np.ndarray) -> None:
        """Integrate one frame with ``inputs`` [4 x steps_per_frame] held per plant step."""
        inputs = np.asarray(inputs, dtype=float)
        count = self.steps_per_frame * self.config.plant.substeps
        dw = wiener_increments(self._process_rng, self.layout, count, self._substep_s)
        states = np.asarray(self._frame(self.state, inputs, dw,
                                        held_parameters(self.parameters, self.steps_per_frame)))
        final = states[:, -1]
        if not np.all(np.isfinite(final)):
            raise PlantDiverged(f"non-finite plant state after inputs {inputs[:, -1]}")
        if self.trip_tank_lined_up:
            gain = self.layout.pit_gain
            self._gain_in_trip_tank_m3 += final[gain] - self.state[gain]
        self.state = final
        self.inputs = inputs[:, -1].copy()
        self._algebraic_now = None

    def set_parameter(self, name: str, value: float) -> None:
        """Change one of PARAMETER_NAMES from the next frame on (a scenario event)."""
        self.parameters[PARAMETER_NAMES.index(name)] = value
        self._algebraic_now = None

    def set_hoisting(self, latched: bool, slips_set: bool) -> None:
        """The rig floor's hoisting mode from the next frame on: the elevator latched to the
        string or not, the slips set or pulled (drill_core.hydraulics.hoisting_acceleration)."""
        self.set_parameter("elevator_latched", float(latched))
        self.set_parameter("slips_set", float(slips_set))

    def line_up_trip_tank(self, lined_up: bool) -> None:
        """The returns and the pumps' suction on the trip tank (True) or the active pit from
        the next frame on: the well's gain and loss then move the trip tank's volume."""
        self.trip_tank_lined_up = bool(lined_up)

    def line_tension_n(self) -> float:
        """The elevator's pull on the string now [N] (0 unlatched)."""
        lay, well = self.layout, self.config.well
        latched = self.parameters[PARAMETER_NAMES.index("elevator_latched")]
        return float(hy.elevator_pull(self.wm.geometry, well.hoist_damping_n_s_m,
                                      self.state[lay.position], self.state[lay.velocity],
                                      self.inputs[U_BLOCK], latched))

    def _algebraic(self) -> np.ndarray:
        """The algebraic outputs at the current state, evaluated once per frame for the
        sensors and the truth."""
        if self._algebraic_now is None:
            self._algebraic_now = np.asarray(
                self._outputs(self.state, self.inputs, self.parameters)).ravel()
        return self._algebraic_now

    def measure(self, circulating: bool) -> Measurement:
        """Sensors of eq. 48 and the surface-flow sensors (return flow, pit volume) with the
        configured noise; no string flow while not circulating."""
        lay, noise, x = self.layout, self.config.plant.measurement_noise, self.state
        bias = self.config.plant.sensor_bias
        draw = self._sensor_rng.normal(size=4)
        index, offset = self._sensors
        y = [x[i] - o for i, o in zip(index, offset)]          # h(x), eq. 48
        flow = y[3] + noise.string_flow_m3s * draw[3] + bias.string_flow_m3s
        surface, surface_noise = self._surface_rng.normal(size=3), self.config.plant.surface_sensor_noise
        floor = self._floor_rng.normal(size=2)
        returns = self._algebraic()[0] + bias.return_flow_m3s
        return Measurement(
            block_position_m=float(y[0] + noise.block_position_m * draw[0]),
            choke_dp_pa=float(y[1] + noise.choke_dp_pa * draw[1] + bias.choke_dp_pa),
            bhp_pa=float(y[2] + noise.bhp_pa * draw[2] + bias.bhp_pa),
            string_flow_m3s=float(flow) if circulating else float("nan"),
            string_flow_valid=circulating,
            return_flow_m3s=float(returns) + surface_noise.return_flow_m3s * float(surface[0]),
            pit_volume_m3=float(self.config.plant.active_pit_volume_m3 + x[lay.pit_gain]
                                - self._gain_in_trip_tank_m3
                                + surface_noise.pit_volume_m3 * surface[1]),
            bpp_flow_m3s=float(self.inputs[U_BPP_FLOW] + surface_noise.bpp_flow_m3s * surface[2]),
            hook_load_n=float(self.config.well.travelling_block_weight_n + self.line_tension_n()
                              + surface_noise.hook_load_n * floor[0]),
            trip_tank_volume_m3=float(self.config.plant.trip_tank_volume_m3
                                      + self._gain_in_trip_tank_m3
                                      + surface_noise.trip_tank_volume_m3 * floor[1]))

    def truth(self) -> Truth:
        out = self._algebraic()
        n, lay = self.wm.n, self.layout
        g = self.config.well.gravity_mps2
        bhp = self.state[lay.pressure(n)]
        return Truth(state=self.state.copy(), inputs=self.inputs.copy(),
                     choke_flow_m3s=float(out[0]), bit_flow_m3s=float(out[1]),
                     annulus_friction_pa=out[2:2 + n - 1].copy(),
                     string_friction_pa=float(out[1 + n]),
                     ecd_kgm3=float(equivalent_density_kgm3(
                         bhp, self.wm.geometry.node_depth_m[-1], g)),
                     influx_m3s=float(out[2 + n]), loss_m3s=float(out[3 + n]),
                     pit_gain_m3=float(self.state[lay.pit_gain]),
                     influx_volume_m3=float(self.state[lay.influx_volume]),
                     loss_volume_m3=float(self.state[lay.loss_volume]),
                     parameters=self.parameters.copy())
