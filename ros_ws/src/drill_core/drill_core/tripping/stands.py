"""The volumes a stand moves and the geometry of the string after whole stands: steel
(open-end) displacement, closed-end displacement and the pipe's contents, from the top
string section's areas (drill_core.well, tool joints smeared)."""
from __future__ import annotations

from dataclasses import dataclass

from drill_core.config import Well
from drill_core.well import WellGeometry, build_geometry


@dataclass(frozen=True)
class StandVolumes:
    """What one stand of the top section displaces [m^3]."""
    steel_m3: float          # open-end: the pipe's steel
    closed_end_m3: float     # steel plus contents: a pipe pulled wet or run in with a float
    contents_m3: float       # the mud inside the stand

    @classmethod
    def of(cls, geometry: WellGeometry, stand_length_m: float) -> "StandVolumes":
        outer = geometry.string_outer_area_at_top_m2 * stand_length_m
        inner = geometry.string_top_inner_area_m2 * stand_length_m
        return cls(steel_m3=outer - inner, closed_end_m3=outer, contents_m3=inner)

    def hole_fill_m3(self, wet: bool = False) -> float:
        """The mud the hole takes when the stand is pulled (dry: the pipe drains into the
        well, the fill is its steel; wet: its contents leave with it, the closed end)."""
        return self.closed_end_m3 if wet else self.steel_m3


def tripped_geometry(well: Well, stands_pulled: int, stand_length_m: float) -> WellGeometry:
    """The geometry with ``stands_pulled`` stands racked back (0: the string as configured)."""
    return build_geometry(well, stands_pulled * stand_length_m)
