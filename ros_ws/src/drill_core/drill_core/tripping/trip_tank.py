"""The trip tank: a small calibrated tank the well is filled from (pulling out) and returns
to (running in), so the mud a trip moves is read as a level. Mass balance of
incompressible mud: dV/dt = q_returned - q_drawn [m^3/s], level h = V / A."""
from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class TripTank:
    """The tank's state: its cross-section [m^2], the mud in it [m^3] and the mud asked of
    it after it ran dry, which it could not give [m^3]."""
    area_m2: float
    volume_m3: float
    shortfall_m3: float = 0.0

    @property
    def level_m(self) -> float:
        return self.volume_m3 / self.area_m2

    def step(self, returned_m3s: float, drawn_m3s: float, dt_s: float) -> "TripTank":
        """The tank ``dt_s`` later with ``returned_m3s`` flowing in from the well's returns
        and ``drawn_m3s`` out to the well (fill line or pump suction); an empty tank gives
        nothing more and counts what it could not give."""
        volume = self.volume_m3 + (returned_m3s - drawn_m3s) * dt_s
        return replace(self, volume_m3=max(volume, 0.0),
                       shortfall_m3=self.shortfall_m3 + max(-volume, 0.0))
