"""What a multi-stand trip is asked to do: its direction, stands, connections, pump ramps
and the trip sheet's alarm limit (a scenario's ``trip:`` mapping; SI units). The trip
tank itself is the rig's (config/plant.yaml)."""
from __future__ import annotations

from dataclasses import dataclass

from drill_core.schema import param

DIRECTIONS = ("out", "in")


@dataclass(frozen=True)
class TripProgramme:
    """One trip: ``stands`` stands of ``stand_length_m`` pulled out or run in."""
    direction: str = param(choices=DIRECTIONS, doc="out: pull out of the hole; in: run in")
    stands: int = param("1", 1, 200)
    stand_length_m: float = param("m", 5.0, 45.0, default=28.0, doc="a stand of three joints")
    connection_s: float = param("s", 0.0, 3600.0, default=90.0,
                                doc="slips to slips: the break-out (out) or make-up (in) time")
    pump_ramp_down_s: float = param("s", 0.0, 600.0, default=30.0,
                                    doc="the mud pump from its rate to off before a connection")
    pump_stop_share: float | None = param(
        "1", 0.0, 0.95, default=None,
        doc="the ramp-down's shape (unset: the pump's share of its stand-pipe pressure falls "
            "linearly to off): the share s0 at which the bit's flow stops, the share then "
            "falling as s0 + (1 - s0)(1 - t/T)^2 to the pump's stop at the ramp's end, so "
            "that the flow falls about linearly, as a rig steps its pump down")
    pump_ramp_up_s: float = param("s", 0.0, 600.0, default=30.0,
                                  doc="the mud pump from off back to its rate after it")
    pickup_margin_n: float = param(
        "N", 0.0, 1.0e6, default=0.0,
        doc="the slips are pulled once the elevator carries the string's weight less this "
            "(0: once the line lifts the string off them, when they carry nothing)")
    discrepancy_alarm_m3: float = param(
        "m^3", 0.0, 10.0, lo_open=True, default=0.3,
        doc="the trip sheet alarms when measured and expected fill differ by more")
    settle_s: float | None = param(
        "s", 0.1, 3600.0, default=None,
        doc="the run ends this long after the trip is done (unset: at the scenario's "
            "duration_s, which caps it in any case)")

    @property
    def stands_pulled_at_start(self) -> int:
        """Stands off the configured string as the trip starts: none pulling out; running
        in, the trip's stands, racked at the start (the trip ends on the configured
        string, the bit where it was configured)."""
        return self.stands if self.direction == "in" else 0

    @property
    def pulled_at_start_m(self) -> float:
        """The string's length off the configured one as the trip starts [m]."""
        return self.stands_pulled_at_start * self.stand_length_m
