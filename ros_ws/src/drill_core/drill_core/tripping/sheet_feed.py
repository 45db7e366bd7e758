"""A trip sheet (drill_core.tripping.trip_sheet) fed from the rig's streams as they come:
the rig floor's step per frame, the measurements, and the BHP reference and band in force.
A measurement stamped t_k is read with the floor's step for the frame before it, t_k - dt
(the one the plant ran under up to t_k), once that step has come
(drill_core.tripping.frame_pairs); a measurement whose step will not come (none before
the first floor step) is passed over. The report of a
recording and the operator console each feed one."""
from __future__ import annotations

import math

from drill_core.event_codes import Notice
from drill_core.tripping.frame_pairs import FramePairs
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.sequence import TripStep
from drill_core.tripping.stands import StandVolumes
from drill_core.tripping.trip_sheet import TripSheet


class TripSheetFeed:
    """``floor``, ``measurement`` and ``reference`` in any order; ``sheet`` has the rows."""

    def __init__(self, programme: TripProgramme, volumes: StandVolumes, frame_ns: int):
        self.sheet = TripSheet(programme, volumes, math.nan)
        self.bhp_ref_pa = math.nan
        self.pairs = FramePairs(frame_ns)    # (BHP Pa, trip tank m^3) with the floor's step
        self.alarms: list[Notice] = []

    def reference(self, bhp_ref_pa: float, bhp_band_pa: float) -> None:
        """The BHP reference and the band's half-width in force from now on [Pa]."""
        self.bhp_ref_pa = float(bhp_ref_pa)
        self.sheet.band_pa = float(bhp_band_pa)

    def floor(self, stamp_ns: int, step: TripStep) -> list[Notice]:
        """The floor's step for the frame from ``stamp_ns``; the alarms of the rows it closed."""
        return self._observe(self.pairs.partner(stamp_ns, step))

    def measurement(self, stamp_ns: int, bhp_pa: float, trip_tank_m3: float) -> list[Notice]:
        """A measurement stamped ``stamp_ns``: BHP [Pa] and the trip tank's volume [m^3]."""
        return self._observe(self.pairs.item(stamp_ns, (float(bhp_pa), float(trip_tank_m3))))

    def _observe(self, released) -> list[Notice]:
        notices = []
        for stamp, (bhp_pa, tank_m3), step in released:
            if step is not None:
                notices += self.sheet.observe(stamp * 1e-9, step, bhp_pa, self.bhp_ref_pa, tank_m3)
        self.alarms += notices
        return notices
