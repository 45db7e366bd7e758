"""Validation of operator setpoints against the actuator envelope and the pressure window.

Plain module (no rclpy). The supervisor's /set_setpoints service adopts a request only
when :func:`validate_setpoints` accepts it; a refusal names the field, the requested value
and the allowed range (SI, with drilling units in brackets for the operator).

Pressure window: ``RigConfig.pressure_window_pa``, config/well.yaml's formation (pore and
fracture pressure at the BHP depth) less protection.yaml's ``pressure_margin_pa`` at both
edges -- the same window the process-protection layer enforces. A BHP target is accepted when its whole band lies inside
the window less the margin and the target is above the static mud column (the BHP can only
be raised above hydrostatic by friction and choke back-pressure, never lowered below it).
Trip speed: at most the smaller of the NMPC's string-velocity limit and the drawworks'
machine limit (protection ``trip_speed_max_mps``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drill_core.config import RigConfig
from drill_core.units import PA_PER_BAR
from drill_core.well import WellGeometry
from drill_core.scenario import SETPOINT_NUMERIC_FIELDS


def _bar(pa: float) -> str:
    return f"{pa:.6g} Pa ({pa / PA_PER_BAR:.2f} bar)"


@dataclass(frozen=True)
class Envelope:
    """What a setpoint may ask for (SI)."""
    pore_pressure_pa: float        # window floor, margin included
    fracture_pressure_pa: float    # window ceiling, margin included
    hydrostatic_pa: float          # static mud column at the BHP sensor depth
    choke_dp_max_pa: float         # choke back-pressure that keeps a static BHP below fracture
    block_min_m: float
    block_max_m: float
    speed_max_mps: float

    @classmethod
    def from_config(cls, config: RigConfig, geometry: WellGeometry) -> "Envelope":
        n, p = config.nmpc, config.protection
        w = config.well
        hydrostatic = w.mud.density_kgm3 * w.gravity_mps2 * geometry.node_depth_m[-1]
        dw = config.actuators.drawworks
        pore, fracture = config.pressure_window_pa
        return cls(
            pore_pressure_pa=pore,
            fracture_pressure_pa=fracture,
            hydrostatic_pa=hydrostatic,
            choke_dp_max_pa=max(fracture - hydrostatic, 0.0),
            block_min_m=max(n.input_min.block_position_m, dw.minimum),
            block_max_m=min(n.input_max.block_position_m, dw.maximum),
            speed_max_mps=min(n.velocity_limit_mps, p.trip_speed_max_mps),
        )


NUMERIC_FIELDS = SETPOINT_NUMERIC_FIELDS


def validate_setpoints(sp, envelope: Envelope) -> tuple[bool, str]:
    """(ok, reason): ``sp`` has the fields of drill_msgs/Setpoints / ActiveSetpoints (SI).

    Every numeric field must be finite (resolve "keep the value in force" before calling).
    """
    for name in NUMERIC_FIELDS:
        value = getattr(sp, name)
        if not isinstance(value, (int, float)) or not math.isfinite(float(value)):
            return False, f"{name} = {value!r} is not a finite number"
    e = envelope
    if sp.bhp_band_pa <= 0.0:
        return False, f"bhp_band_pa = {_bar(sp.bhp_band_pa)} must be positive"
    if sp.choke_dp_band_pa <= 0.0:
        return False, f"choke_dp_band_pa = {_bar(sp.choke_dp_band_pa)} must be positive"
    if sp.choke_dp_band_upper_pa < 0.0:
        return False, (f"choke_dp_band_upper_pa = {_bar(sp.choke_dp_band_upper_pa)} must not be "
                       "negative (0: the band is symmetric)")
    if sp.bhp_ref_pa < e.hydrostatic_pa:
        return False, (f"bhp_ref_pa = {_bar(sp.bhp_ref_pa)} is below the static mud column "
                       f"{_bar(e.hydrostatic_pa)}: unreachable (BHP can only be raised above it)")
    if sp.bhp_ref_pa - sp.bhp_band_pa < e.pore_pressure_pa:
        return False, (f"BHP band bottom bhp_ref_pa - bhp_band_pa = {_bar(sp.bhp_ref_pa - sp.bhp_band_pa)}"
                       f" is below the pore pressure + margin {_bar(e.pore_pressure_pa)} (influx risk)")
    if sp.bhp_ref_pa + sp.bhp_band_pa > e.fracture_pressure_pa:
        return False, (f"BHP band top bhp_ref_pa + bhp_band_pa = {_bar(sp.bhp_ref_pa + sp.bhp_band_pa)}"
                       f" is above the fracture pressure - margin {_bar(e.fracture_pressure_pa)} (losses risk)")
    if not 0.0 <= sp.choke_dp_ref_pa <= e.choke_dp_max_pa:
        return False, (f"choke_dp_ref_pa = {_bar(sp.choke_dp_ref_pa)} is outside [0, "
                       f"{_bar(e.choke_dp_max_pa)}] (fracture pressure - margin - static column)")
    if not e.block_min_m <= sp.block_position_target_m <= e.block_max_m:
        return False, (f"block_position_target_m = {sp.block_position_target_m:g} m is outside "
                       f"the drawworks range [{e.block_min_m:g}, {e.block_max_m:g}] m")
    if not 0.0 < sp.trip_speed_limit_mps <= e.speed_max_mps:
        return False, (f"trip_speed_limit_mps = {sp.trip_speed_limit_mps:g} m/s is outside "
                       f"(0, {e.speed_max_mps:g}] m/s (string velocity limit)")
    return True, ""
