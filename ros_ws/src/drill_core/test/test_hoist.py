"""The string on the slips and the elevator: the elevator's force is the paper's hoisting
equation, the slips hold the string until the line lifts it, and the hand-over is free of
force jumps."""

import pytest

from drill_core.config import load_rig
from drill_core.hydraulics import build_well_model, hoisting_acceleration
from drill_core.rig_root import config_dir
from drill_core.tripping.hoist import buoyed_weight_n, hoist_forces
from drill_core.tripping.stands import tripped_geometry

BLOCK_WEIGHT_N = 3.0e5
G = 9.81


@pytest.fixture(scope="module")
def well():
    return load_rig(config_dir()).well


def _forces(well, geometry, x, v, u_b, latched=True, slips_set=False):
    return hoist_forces(geometry, G, well.hoist_damping_n_s_m, BLOCK_WEIGHT_N, x, v, u_b,
                        latched, slips_set)


def test_on_the_elevator_it_is_the_hoisting_equation_of_the_plant(well):
    wm = build_well_model(well, 1e-3, 1e3)
    for x, v, u_b in ((0.0, 0.0, 1.6), (2.0, 0.4, 3.0), (-1.0, -0.3, 0.2)):
        f = _forces(well, wm.geometry, x, v, u_b)
        assert f.acceleration_mps2 == pytest.approx(hoisting_acceleration(wm, x, v, u_b), rel=1e-12)
        assert f.hook_load_n == pytest.approx(
            BLOCK_WEIGHT_N + well.hoist_stiffness_n_m * (u_b - x) - well.hoist_damping_n_s_m * v)


def test_in_the_slips_with_the_elevator_off_the_hook_carries_the_block_alone(well):
    g = tripped_geometry(well, 3, 28.0)
    f = _forces(well, g, 0.0, 0.0, -5.0, latched=False, slips_set=True)
    weight = g.string_mass_kg * G * (1.0 - 1800.0 / 7850.0)
    assert f.held and f.acceleration_mps2 == 0.0
    assert f.hook_load_n == BLOCK_WEIGHT_N and f.slips_reaction_n == pytest.approx(weight)


def test_slips_pulled_before_the_weight_is_taken_drop_the_string(well):
    g = tripped_geometry(well, 0, 28.0)
    u_b = 0.5 * g.static_stretch_m            # the line carries half the weight
    f = _forces(well, g, 0.0, 0.0, u_b, slips_set=False)
    assert f.acceleration_mps2 == pytest.approx(-0.5 * G * g.buoyancy_factor, rel=1e-9)


def test_picking_up_off_the_slips_hands_the_string_over_without_a_jump(well):
    """The block rises at 0.1 m/s from a slack line; the slips stay set. Semi-implicit
    Euler at 1 ms: the string lifts when the line carries its weight, and the hook load,
    the slips' force and the string's velocity change by no more per step than the
    block's motion allows; lifted, the string follows the block (lightly damped, its mean
    speed over the last 10 s is the block's)."""
    g = tripped_geometry(well, 2, 28.0)
    weight = buoyed_weight_n(g, G)
    dt, block_speed = 1e-3, 0.1
    x = v = 0.0
    u_b = 0.0
    last = _forces(well, g, x, v, u_b, slips_set=True)
    lifted_at = None
    force_step = g.axial_stiffness_n_m * block_speed * dt
    for i in range(int(30.0 / dt)):
        u_b += block_speed * dt
        f = _forces(well, g, x, v, u_b, slips_set=True)
        if f.held:
            v = 0.0
        else:
            lifted_at = lifted_at if lifted_at is not None else i
            v += f.acceleration_mps2 * dt
            x += v * dt
        if i == int(20.0 / dt):
            x_at_20_s = x
        assert abs(f.hook_load_n - last.hook_load_n) <= 1.05 * force_step
        assert abs(f.slips_reaction_n - last.slips_reaction_n) <= 1.05 * force_step
        last = f
    assert lifted_at is not None
    # it lifts where the line's stretch carries the weight: u_b = W / k
    assert lifted_at * dt * block_speed == pytest.approx(weight / g.axial_stiffness_n_m, abs=2e-3)
    assert last.slips_reaction_n == 0.0
    assert (x - x_at_20_s) / 10.0 == pytest.approx(block_speed, rel=0.02)
