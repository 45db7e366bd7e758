"""The casing shoe: its depth in well.yaml, checked, and the annulus pressure there between
the model's nodes (drill_core.well.annulus_pressure_at_depth_pa)."""
import pytest

from drill_core.config import ConfigError, load_rig
from drill_core.rig_root import config_dir
from drill_core.well import annulus_pressure_at_depth_pa, build_geometry, equivalent_density_kgm3

G = 9.81


@pytest.fixture(scope="module")
def well():
    return load_rig(config_dir()).well


def test_the_shoe_is_the_top_of_the_open_hole(well):
    assert well.casing_shoe_depth_m == pytest.approx(sum(well.segment_lengths_m[:-1]))   # 3276 m


def test_a_static_column_gives_the_muds_density_at_the_shoe(well):
    depths = build_geometry(well).node_depth_m                     # 0, 1638, 2730, 3607.8 m
    rho = well.mud.density_kgm3
    column = [rho * G * d for d in depths]
    p_shoe = annulus_pressure_at_depth_pa(depths, column, well.casing_shoe_depth_m)
    assert p_shoe == pytest.approx(rho * G * 3276.0)               # 578.5 bar
    assert equivalent_density_kgm3(p_shoe, 3276.0, G) == pytest.approx(rho)


def test_circulating_the_shoe_reads_the_friction_above_it(well):
    """Hand numbers: 20 bar at the choke, 1.5 bar of friction per 1000 m of annulus, the
    1800 kg/m^3 column: at 3276 m, 578.5 + 20 + 4.914 bar; ECD 1800 + 24.914e5 / (g 3276)."""
    depths = build_geometry(well).node_depth_m
    pressures = [2.0e6 + 1800.0 * G * d + 150.0 * d for d in depths]
    p_shoe = annulus_pressure_at_depth_pa(depths, pressures, 3276.0)
    assert p_shoe == pytest.approx(1800.0 * G * 3276.0 + 2.0e6 + 4.914e5)
    assert equivalent_density_kgm3(p_shoe, 3276.0, G) == pytest.approx(1877.52, abs=0.01)


def test_a_depth_outside_the_nodes_is_refused(well):
    depths = build_geometry(well).node_depth_m
    with pytest.raises(ValueError, match="outside the nodes"):
        annulus_pressure_at_depth_pa(depths, [0.0] * len(depths), 4000.0)


def test_a_shoe_at_or_below_the_bottom_is_refused_naming_the_key():
    with pytest.raises(ConfigError) as info:
        load_rig(config_dir(), {"well": {"casing_shoe_depth_m": 3620.1}})
    message = str(info.value)
    for part in ("casing_shoe_depth_m", "3620.1 m", "must be above the well's bottom"):
        assert part in message, message
