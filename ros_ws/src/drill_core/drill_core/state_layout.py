"""Named state layouts: where each state of a model sits in its state vector.

A model lists its states by name once (``names``); every index is looked up by that name.
The truth plant and the estimation model share the string motion and the wellbore's
hydraulic states (docs/model.md, "State layouts"), so both read them through
:class:`WellboreLayout` and the shared equations never hard-code an offset.
"""
from __future__ import annotations

import functools
from collections.abc import Mapping

import numpy as np

MEASUREMENT_NAMES = ("block_position_m", "choke_dp_pa", "bhp_pa", "string_flow_m3s")  # eq. 48
POSITION = "string_position_m"
VELOCITY = "string_velocity_mps"
STRING_FLOW = "string_flow_m3s"
STRING_PRESSURE = "string_bottom_pressure_pa"


def annulus_pressure_name(i: int) -> str:
    """Name of p_i, the pressure of annulus control volume i = 1..n [Pa]."""
    return f"annulus_pressure_{i}_pa"


def annulus_flow_name(i: int) -> str:
    """Name of q_i, the flow between annulus control volumes i - 1 and i, i = 2..n [m^3/s]."""
    return f"annulus_flow_{i}_m3s"


def hydraulic_state_names(n: int) -> list[str]:
    """The wellbore's hydraulic states in the paper's order: p_1, q_2, p_2, ..., q_n, p_n,
    q_d, p_I."""
    names = [annulus_pressure_name(1)]
    for i in range(2, n + 1):
        names += [annulus_flow_name(i), annulus_pressure_name(i)]
    return names + [STRING_FLOW, STRING_PRESSURE]


class StateLayout:
    """Index of a model's state vector by state name; a subclass provides ``names``."""

    @property
    def names(self) -> tuple[str, ...]:
        raise NotImplementedError

    @functools.cached_property
    def _positions(self) -> dict[str, int]:
        positions = {name: i for i, name in enumerate(self.names)}
        if len(positions) != len(self.names):
            raise ValueError(f"repeated state name in {self.names}")
        return positions

    @property
    def size(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Position of the state ``name``; KeyError names a state the model does not have."""
        try:
            return self._positions[name]
        except KeyError:
            raise KeyError(f"{type(self).__name__} has no state {name!r}") from None

    def vector(self, values: Mapping[str, float]) -> np.ndarray:
        """This layout's state vector from values keyed by state name (names the layout
        does not hold are ignored); KeyError names a state ``values`` lacks."""
        missing = [name for name in self.names if name not in values]
        if missing:
            raise KeyError(f"no value for the state(s) {missing} of {type(self).__name__}")
        return np.array([float(values[name]) for name in self.names])


class WellboreLayout(StateLayout):
    """A layout holding the string motion and the wellbore hydraulics of ``n`` annulus
    segments (a subclass gives ``n``), the states the shared equations
    (drill_core.hydraulics) read."""

    @property
    def position(self) -> int:
        return self.index(POSITION)

    @property
    def velocity(self) -> int:
        return self.index(VELOCITY)

    def pressure(self, i: int) -> int:
        """Index of p_i, i = 1..n."""
        return self.index(annulus_pressure_name(i))

    def flow(self, i: int) -> int:
        """Index of q_i, i = 2..n."""
        return self.index(annulus_flow_name(i))

    @property
    def string_flow(self) -> int:
        return self.index(STRING_FLOW)

    @property
    def string_pressure(self) -> int:
        return self.index(STRING_PRESSURE)

    def sensor_map(self, downstream_pa: float) -> tuple[np.ndarray, np.ndarray]:
        """The rig's sensors as h(x) = x[index] - offset (paper eq. 48), one row per channel
        of MEASUREMENT_NAMES: the block's position, the choke dp (p_1 less the pressure
        downstream of the choke), the BHP p_n and the string flow. One definition, read by
        the plant's sensors, the UKF and the NMPC."""
        return (np.array([self.position, self.pressure(1), self.pressure(self.n),
                          self.string_flow]),
                np.array([0.0, downstream_pa, 0.0, 0.0]))

    def sensed_states(self, y, downstream_pa: float) -> dict[int, float]:
        """The inverse of ``sensor_map``: state index -> its value for each channel of the
        reading ``y`` (as many channels as it has: three while the pump is off)."""
        index, offset = self.sensor_map(downstream_pa)
        return {int(i): float(v) + float(o) for i, v, o in zip(index, y, offset)}
