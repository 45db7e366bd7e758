"""A report's display units (drill_core.units.Display): the well-control rows in metric
and in field units, worked out here from the definitions (1 psi = 6894.757 Pa, 1 bbl =
0.158987 m^3); an unknown system refused with the ones there are."""
import pytest

from drill_analysis import well_control_report as wc
from drill_core.units import Display

SUMMARY = {"influx_volume_m3": 0.0159, "loss_volume_m3": 0.0, "pit_gain_max_m3": 0.0318,
           "pit_gain_final_m3": 0.0159, "bhp_under_pore_s": 24.1, "worst_underbalance_pa": 4.84e5,
           "bhp_over_fracture_s": 0.0, "detection": {}, "events": []}


def test_metric_rows_are_in_bar_and_litres():
    formation, window = wc.format_rows(SUMMARY)
    assert "influx 16 L, losses 0 L, pit gain max +32 L (final +16 L)" in formation
    assert "(worst 4.84 bar under)" in window


def test_field_rows_are_in_psi_and_barrels():
    formation, window = wc.format_rows(SUMMARY, Display("field"))
    assert f"influx {0.0159 / 0.158987294928:.1f} bbl" in formation            # 0.1 bbl
    assert f"pit gain max +{0.0318 / 0.158987294928:.1f} bbl" in formation     # +0.2 bbl
    assert f"(worst {4.84e5 / 6894.757293168:.2f} psi under)" in window        # 70.20 psi


def test_an_unknown_unit_system_is_refused():
    with pytest.raises(ValueError, match="units: value 'imperial' is not one of metric, field"):
        Display("imperial")
