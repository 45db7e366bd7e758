"""The geometry of a string tripped out by whole stands against hand calculations from the
reference well's diameters (config/well.yaml: 5" drill pipe 127.0 / 108.7 mm with
168.4 / 82.5 mm tool joints 0.25 m in every 9.45 m, collars 127.0 / 81.0 mm, BHA
174.0 / 98.8 mm, 245 mm hole, steel 7850 kg/m^3)."""

import math

import pytest

from drill_core.config import load_rig
from drill_core.hydraulics import bit_pressure_drop
from drill_core.rig_root import config_dir
from drill_core.tripping.stands import StandVolumes, tripped_geometry
from drill_core.well import build_geometry

STAND_M = 28.0
TJ_SHARE = 0.25 / 9.45


def ring(outer_m, inner_m=0.0):
    return math.pi / 4.0 * (outer_m ** 2 - inner_m ** 2)


PIPE_STEEL_M2 = (1 - TJ_SHARE) * ring(0.127, 0.1087) + TJ_SHARE * ring(0.1684, 0.0825)
PIPE_OUTER_M2 = (1 - TJ_SHARE) * ring(0.127) + TJ_SHARE * ring(0.1684)
PIPE_INNER_M2 = (1 - TJ_SHARE) * ring(0.1087) + TJ_SHARE * ring(0.0825)


@pytest.fixture(scope="module")
def well():
    return load_rig(config_dir()).well


def test_the_hand_numbers_of_one_stand():
    # 3.388e-3 m^2 of pipe body and 1.693e-2 m^2 of tool joint, 2.6 % of the length
    assert PIPE_STEEL_M2 == pytest.approx(3.7459e-3, rel=1e-4)
    assert PIPE_STEEL_M2 * STAND_M == pytest.approx(0.10489, rel=1e-4)


def test_a_stand_displaces_its_steel_open_ended_and_its_outer_volume_closed(well):
    v = StandVolumes.of(build_geometry(well), STAND_M)
    assert v.steel_m3 == pytest.approx(PIPE_STEEL_M2 * STAND_M, rel=1e-12)
    assert v.closed_end_m3 == pytest.approx(PIPE_OUTER_M2 * STAND_M, rel=1e-12)
    assert v.contents_m3 == pytest.approx(PIPE_INNER_M2 * STAND_M, rel=1e-12)
    assert v.hole_fill_m3(wet=False) == v.steel_m3 and v.hole_fill_m3(wet=True) == v.closed_end_m3


def test_each_stand_racked_back_takes_its_steel_mass_and_contents_off_the_string(well):
    for stands in (0, 4, 9):
        before = tripped_geometry(well, stands, STAND_M)
        after = tripped_geometry(well, stands + 1, STAND_M)
        assert before.string_mass_kg - after.string_mass_kg == pytest.approx(
            PIPE_STEEL_M2 * STAND_M * 7850.0, rel=1e-9)
        assert before.string_volume_m3 - after.string_volume_m3 == pytest.approx(
            PIPE_INNER_M2 * STAND_M, rel=1e-9)
        assert before.bit_depth_m - after.bit_depth_m == pytest.approx(STAND_M, abs=1e-9)


def test_ten_stands_out_leave_open_hole_below_the_bit_and_the_nodes_in_place(well):
    full, out = build_geometry(well), tripped_geometry(well, 10, STAND_M)
    assert out.node_depth_m == full.node_depth_m
    assert out.bit_above_bhp_node_m == pytest.approx(280.0, abs=1e-9)
    # the bottom segment (3276.0-3620.1 m) holds only the BHA's lowest 51.8 m now
    assert out.annulus_volume_m3[-1] == pytest.approx(
        ring(0.245) * 344.1 - ring(0.174) * 51.8, rel=1e-9)
    open_hole = [s for s in out.annulus_paths[-1] if s.hydraulic_diameter_m == 0.245]
    assert sum(s.length_m for s in open_hole) == pytest.approx(280.0, abs=1e-9)
    assert all(s.flow_area_m2 == pytest.approx(ring(0.245)) and s.clinging == 0.0
               for s in open_hole)
    # the steel the string still has in the well's closed volume is what it displaces
    assert sum(out.displacement_area_m2) == pytest.approx(PIPE_OUTER_M2, rel=1e-9)


def test_a_shorter_string_is_stiffer_in_the_ratio_of_its_axial_compliance(well):
    def compliance(pipe_m):
        pipe = pipe_m * ((1 - TJ_SHARE) / ring(0.127, 0.1087) + TJ_SHARE / ring(0.1684, 0.0825))
        return pipe + 251.1 / ring(0.127, 0.081) + 60.0 / ring(0.174, 0.0988)

    full, out = build_geometry(well), tripped_geometry(well, 10, STAND_M)
    assert full.axial_stiffness_n_m == well.hoist_stiffness_n_m
    assert out.axial_stiffness_n_m == pytest.approx(
        well.hoist_stiffness_n_m * compliance(3296.7) / compliance(3016.7), rel=1e-9)
    weight = out.string_mass_kg * 9.81 * (1.0 - 1800.0 / 7850.0)
    assert out.static_stretch_m == pytest.approx(weight / out.axial_stiffness_n_m, rel=1e-12)


def test_the_annulus_pressure_at_a_pulled_bit_is_the_bhp_less_the_column_between(well):
    out = tripped_geometry(well, 10, STAND_M)
    rho_g = 1800.0 * 9.81
    p_string, bhp = 6.9e7, 6.85e7
    for position in (0.0, 3.5):
        annulus_at_bit = bhp - rho_g * (280.0 + position)
        assert bit_pressure_drop(out, p_string, bhp, rho_g, position) == pytest.approx(
            p_string - annulus_at_bit, rel=1e-12)


def test_a_trip_past_the_top_section_is_refused_with_the_allowed_range(well):
    for pulled in (-1.0, 3296.7):
        with pytest.raises(ValueError, match=r"pulled_m = .* allowed 0 <= pulled_m < 3296.7 m"):
            build_geometry(well, pulled)
