"""Values with units in configuration and scenario files (drill_core.quantities through
drill_core.schema): converted to the field's SI unit at load, checked against the
definitions (1 bar = 1e5 Pa, 1 psi = 6894.757 Pa, 1 ppg = 119.826 kg/m^3, 1 US gal =
3.785411784 L, 1 ft = 0.3048 m); a unit of the wrong kind, a missing unit or a value out
of range refused naming the key; a file of plain numbers never imports pint."""
import math
import subprocess
import sys

import pytest

from drill_core.config import ConfigError, Mud
from drill_core.quantities import to_si
from drill_core.rig_root import config_dir
from drill_core.scenario import load_scenario
from drill_core.schema import build

MUD = {"bulk_modulus_pa": 6.5e9, "yield_stress_pa": 15.0, "annulus_yield_stress_pa": 15.0,
       "consistency_pa_sn": 0.15, "flow_index": 0.79}


@pytest.mark.parametrize("text, unit, si", [
    ("685 bar", "Pa", 6.85e7), ("5000 psi", "Pa", 5000 * 6894.757293168),
    ("10.5 ppg", "kg/m^3", 10.5 * 119.8264273), ("1.86 sg", "kg/m^3", 1860.0),
    ("1000 L/min", "m^3/s", 1000 / 60000), ("264.172 gpm", "m^3/s", 264.172 * 3.785411784e-3 / 60),
    ("90 ft", "m", 27.432), ("1.64 ft/s", "m/s", 1.64 * 0.3048), ("6.5 GPa", "Pa", 6.5e9),
    ("10 bbl", "m^3", 10 * 0.158987294928)])
def test_a_quantity_becomes_the_si_number(text, unit, si):
    assert to_si(text, unit) == pytest.approx(si, rel=1e-9)


def test_a_field_takes_a_quantity_under_its_name_or_without_its_suffix():
    mud = build(Mud, {**MUD, "density_kgm3": "15 ppg"})
    assert mud.density_kgm3 == pytest.approx(15 * 119.8264273)
    assert build(Mud, {**MUD, "density": "1.8 sg"}).density_kgm3 == pytest.approx(1800.0)


@pytest.mark.parametrize("data, reason", [
    ({"density_kgm3": "2 furlong"}, r"mud.density_kgm3: value '2 furlong' must be a number in \[500, 3000\] kg/m\^3 or a quantity of that unit: .* is not a quantity of kg/m\^3"),
    ({"density_kgm3": "1800"}, "has no unit"),
    ({"density_kgm3": "30 ppg"}, r"value '30 ppg' \(3594.79 kg/m\^3\) is outside the allowed range"),
    ({"density": 1800.0}, r"mud.density: value 1800.0 needs its unit"),
])
def test_a_bad_quantity_is_refused_naming_the_key(data, reason):
    with pytest.raises(ConfigError, match=reason):
        build(Mud, {**MUD, "density_kgm3": 1800.0, **data}
              if "density_kgm3" in data else {**MUD, **data}, "well.yaml", "mud")


def test_a_scenario_in_field_units_is_the_si_one(tmp_path):
    src = (config_dir() / "scenarios" / "case2.yaml").read_text()
    for si, field in (("bhp_ref_pa: 6.85e7 ", "bhp_ref: 685 bar "),
                      ("circulation_m3s: 0.016667 ", "circulation: 1000.02 L/min "),
                      ("choke_dp_pa: 2.0e6 ", "choke_dp: 290.075 psi ")):
        assert si in src
        src = src.replace(si, field)
    (tmp_path / "case2.yaml").write_text(src)
    written, _ = load_scenario(tmp_path / "case2.yaml")
    committed, _ = load_scenario(config_dir() / "scenarios" / "case2.yaml")
    assert written.schedule[0].bhp_ref_pa == committed.schedule[0].bhp_ref_pa
    assert math.isclose(written.initial.circulation_m3s, committed.initial.circulation_m3s,
                        rel_tol=1e-6)
    assert math.isclose(written.initial.choke_dp_pa, committed.initial.choke_dp_pa, rel_tol=1e-5)


def test_plain_numbers_never_import_pint():
    code = ("import sys; from drill_core.config import load_rig; "
            "from drill_core.rig_root import config_dir; load_rig(config_dir()); "
            "print('pint' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
