"""The plant node's per-frame logic as a plain tick class (no rclpy): the truth plant
(drill_plant.simulator) in the world of the scenario's events (drill_core.events) -
formation and choke-plugging events change its parameters when they start, sensor faults
change the published samples, every event is announced when it starts and when it ends -
advanced frame by frame on the actuators' outputs, a bad frame held at the last input; on a
multi-stand trip the rig floor's slips, elevator and racked stands act on it from the
frame the floor decided them for, and the trip tank is lined up from the start.
The plant node moves messages in and out; the in-process loop bench
(drill_studies.loop_bench) steps the same class.
"""
from __future__ import annotations

import numpy as np

from drill_core.config import RigConfig
from drill_core.event_codes import Notice, scenario_notice
from drill_core.events import ACTUATORS
from drill_plant.plant_model import EVENT_PARAMETERS, plant_steady_state
from drill_plant.sensor_faults import SensorFaults
from drill_plant.simulator import Measurement, PlantSimulator


class PlantTick:
    """``sample`` at each sensor time, ``advance`` over the frame with the actuators'
    outputs."""

    def __init__(self, config: RigConfig, op, scenario, seed: int):
        """The truth plant of ``config`` at rest at the operating point ``op``
        (drill_core.operating_point, of the string the scenario starts with) with
        ``scenario``'s events, noise seeded by ``seed``."""
        self.sim = PlantSimulator(config, plant_steady_state(len(op.annulus_pressure_pa), op),
                                  seed, scenario.pulled_at_start_m)
        self.circulating = scenario.initial.circulation_m3s > 0.0
        self.events = scenario.events
        self.sensor_faults = SensorFaults(self.events, seed)
        self._announced: set[tuple[int, str]] = set()     # (event index, "starts" | "ends")
        self.multi_stand = scenario.trip is not None
        if self.multi_stand:
            self.sim.line_up_trip_tank(True)

    def sample(self, time_s: float) -> tuple[list[Notice], Measurement]:
        """The scenario events' edges due by ``time_s`` [s] (a parameter event acts as it
        starts), then the sensors' sample with their faults."""
        notices = []
        for i, event in enumerate(self.events):
            for edge, at_s in (("starts", event.time_s), ("ends", event.end_s)):
                if (i, edge) in self._announced or time_s + 1e-9 < at_s:
                    continue
                self._announced.add((i, edge))
                if edge == "starts" and event.kind in EVENT_PARAMETERS:
                    self.sim.set_parameter(EVENT_PARAMETERS[event.kind], event.value)
                notices.append(scenario_notice(event, edge == "ends"))
        return notices, self.sensor_faults.apply(time_s, self.sim.measure(self.circulating))

    def floor(self, command) -> None:
        """The rig floor's command for the coming frame (drill_core.tripping.rig_floor
        FloorCommand): the stands racked at it, the elevator and the slips."""
        if command.racked_to_m is not None:
            self.sim.rack_string(command.racked_to_m)
        self.sim.set_hoisting(command.step.latched, command.step.slips_set)

    def advance(self, frames: dict) -> list[str]:
        """The plant over one frame; ``frames`` maps each actuator (drill_core.events.ACTUATORS)
        to its (output samples, command) [SI]. A frame of the wrong length or with a
        non-finite sample is held at that input's last value; the errors saying so are
        returned. Raises simulator.PlantDiverged."""
        rows, errors = [], []
        for i, name in enumerate(ACTUATORS):
            samples = np.asarray(frames[name][0], dtype=float)
            if samples.size != self.sim.steps_per_frame or not np.all(np.isfinite(samples)):
                errors.append(f"{name}: bad frame ({samples.size} samples); holding last input")
                samples = np.full(self.sim.steps_per_frame, self.sim.inputs[i])
            rows.append(samples)
        self.circulating = bool(frames["mud_pump"][1] > 0.0)
        self.sim.advance(np.vstack(rows))
        return errors
