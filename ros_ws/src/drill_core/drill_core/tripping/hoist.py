"""The string on the elevator or in the slips: the forces that hold it and the hook load.

On the elevator the hoisting line carries the string through the equivalent spring and
damper of the paper's eq. 35 (drill_core.hydraulics.line_tension; k: the geometry's axial
stiffness). The slips are a one-sided support at the rotary table: set, they hold the
string at rest for as long as the line carries less than its buoyed weight W = m g F_b;
the moment the line carries W the slips carry nothing, so lifting the string off them
hands it to the elevator without a jump in force. With the elevator unlatched the block
moves free and the hook carries only the block's own weight.
"""
from __future__ import annotations

from dataclasses import dataclass

from drill_core.hydraulics import elevator_pull, slips_hold
from drill_core.well import WellGeometry


@dataclass(frozen=True)
class HoistForces:
    """The forces on the string at one instant [N] and its acceleration [m/s^2]."""
    line_tension_n: float      # the elevator's pull on the string (0 unlatched)
    slips_reaction_n: float    # the slips' push (0 on the elevator)
    hook_load_n: float         # what the hook carries: the block and the line
    acceleration_mps2: float
    held: bool                 # the slips hold the string: position fixed, velocity 0


def buoyed_weight_n(geometry: WellGeometry, gravity_mps2: float) -> float:
    """W = m g F_b: the string's weight in the mud [N]."""
    return geometry.string_mass_kg * gravity_mps2 * geometry.buoyancy_factor


def hoist_forces(geometry: WellGeometry, gravity_mps2: float, damping_n_s_m: float,
                 block_weight_n: float, position_m: float, velocity_mps: float,
                 block_position_m: float, latched: bool, slips_set: bool) -> HoistForces:
    """The string's forces and acceleration for block position ``block_position_m`` [m],
    string position and velocity (positive up), the elevator ``latched`` or not and the
    slips ``slips_set`` or not. Set slips hold a string that is not rising and that the line
    does not lift; the integrator then keeps it where it is, at rest."""
    tension = elevator_pull(geometry, damping_n_s_m, position_m, velocity_mps,
                            block_position_m, float(latched))
    net = tension - buoyed_weight_n(geometry, gravity_mps2)
    held = bool(slips_hold(slips_set, velocity_mps, net))
    reaction = -net if held else 0.0
    return HoistForces(line_tension_n=tension, slips_reaction_n=reaction,
                       hook_load_n=block_weight_n + tension,
                       acceleration_mps2=0.0 if held else net / geometry.string_mass_kg,
                       held=held)
