"""Tests of the configuration loader (drill_core.config / drill_core.schema).

The shipped config/ must load and carry the paper's values; every kind of bad input
must be refused with a ConfigError whose message names the file, the key path, the
bad value and what is allowed. Bad configs are written into a tmp_path copy of config/.
"""
from __future__ import annotations

import math
import os
import shutil
from pathlib import Path

import pytest
import yaml

from drill_core.config import ConfigError, RigConfig, load_rig
from drill_core.rig_root import config_dir
from drill_core.yaml_files import load_yaml

CONFIG_DIR = config_dir()


# ----------------------------------------------------------------------- helpers
@pytest.fixture
def cfg(tmp_path: Path) -> Path:
    """A private copy of the shipped config/ directory."""
    target = tmp_path / "config"
    shutil.copytree(CONFIG_DIR, target)
    return target


def _walk(data: object, path: tuple) -> tuple[object, object]:
    """Container and last key of ``path`` (keys and list indices) inside ``data``."""
    for key in path[:-1]:
        data = data[key]
    return data, path[-1]


def set_key(directory: Path, stem: str, path: tuple, value: object) -> Path:
    """Set one value (``path`` = keys / list indices) in ``directory/stem.yaml``."""
    file = directory / f"{stem}.yaml"
    data = load_yaml(file)          # the project's loader: 6.5e9 stays a float
    parent, key = _walk(data, path)
    parent[key] = value
    file.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return file


def del_key(directory: Path, stem: str, path: tuple) -> Path:
    file = directory / f"{stem}.yaml"
    data = load_yaml(file)
    parent, key = _walk(data, path)
    del parent[key]
    file.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return file


def load_error(directory: Path) -> str:
    with pytest.raises(ConfigError) as info:
        load_rig(directory)
    return str(info.value)


def assert_names(message: str, *parts: str) -> None:
    """The message contains every part (file, key path, value, allowed range ...)."""
    missing = [p for p in parts if p not in message]
    assert not missing, f"error message lacks {missing}:\n{message}"


# ------------------------------------------------------------- the shipped config
def test_shipped_config_loads_with_paper_values():
    rig = load_rig(CONFIG_DIR)
    assert isinstance(rig, RigConfig)
    well = rig.well
    # Tengesdal & Holden 2020, Table 2: 4 annulus segments, 3620.1 m in all
    assert well.segment_lengths_m == (1092.0, 1092.0, 1092.0, 344.1)
    assert len(well.segment_lengths_m) == 4
    assert [s.name for s in well.string] == ["drill_pipe", "collars", "bha"]
    assert sum(s.length_m for s in well.string) == pytest.approx(3607.8)
    assert well.hole_diameter_m == 0.245
    assert well.mud.density_kgm3 == 1800.0
    assert well.mud.bulk_modulus_pa == 6.5e9
    assert isinstance(well.mud.bulk_modulus_pa, float)
    assert well.mud.flow_index == 0.79
    assert well.turbulence.annulus_model == "dodge_metzner"
    # K_b = 0.005 bar min/L in the paper; 1 bar = 1e5 Pa, 1 min = 60 s, 1 L = 1e-3 m^3
    k_b_paper = 0.005 * 1.0e5 * 60.0 / 1.0e-3
    assert k_b_paper == pytest.approx(3.0e7)
    assert well.bha_loss_coefficient_pa_s_m3 == pytest.approx(k_b_paper, rel=1e-12)
    assert well.hoist_stiffness_n_m == 563.0e3
    assert well.hoist_damping_n_s_m == 25.0e3
    # plant: 100 Hz steps, 10 Hz sensors
    assert rig.plant.step_s == 0.01
    assert rig.plant.sensor_period_s == 0.1
    assert rig.plant.steps_per_frame == 10
    # choke PI (paper: k_p = 0.08, T_i = 2 s)
    assert rig.actuators.choke_kp == 0.08
    assert rig.actuators.choke_ti_s == 2.0
    assert rig.nmpc.configuration in ("NMPC0", "NMPC1", "NMPC2")
    # prediction horizon: the paper's 15 samples; control horizon: the whole horizon (paper
    # 3), so the choke set-point can follow the planned trip (docs/nmpc.md)
    assert rig.nmpc.prediction_steps == 15 and rig.nmpc.control_steps == 15
    assert rig.estimator.estimate_bottom_influx is False
    assert rig.estimator.nis_window == 50 and isinstance(rig.estimator.nis_window, int)


def test_config_objects_are_frozen():
    rig = load_rig(CONFIG_DIR)
    with pytest.raises(Exception):
        rig.well.mud.density_kgm3 = 1000.0  # type: ignore[misc]


def test_round_trip_copy_loads_identically(cfg):
    """The test helpers' YAML rewrite does not change the configuration by itself."""
    for stem in ("well", "plant", "actuators", "estimator", "nmpc"):
        set_key(cfg, stem, ("__touch__",), 0)
        del_key(cfg, stem, ("__touch__",))
    a, b = load_rig(CONFIG_DIR), load_rig(cfg)
    assert (a.well, a.plant, a.actuators, a.estimator, a.nmpc) == \
           (b.well, b.plant, b.actuators, b.estimator, b.nmpc)


# --------------------------------------------------------------- numbers / ranges
@pytest.mark.parametrize("path, value, key, allowed", [
    (("string", 0, "length_m"), -100.0, "string[0].length_m", "(0, 20000] m"),
    (("segment_lengths_m", 2), -1.5, "segment_lengths_m[2]", "(0, 20000] m"),
    (("hole_diameter_m",), -0.245, "hole_diameter_m", "(0, 2] m"),
])
def test_negative_length(cfg, path, value, key, allowed):
    file = set_key(cfg, "well", path, value)
    assert_names(load_error(cfg), str(file), key, repr(value), allowed)


def test_zero_length_refused_where_range_is_open(cfg):
    file = set_key(cfg, "well", ("string", 1, "length_m"), 0.0)
    assert_names(load_error(cfg), str(file), "string[1].length_m", "0.0", "(0, 20000] m")


@pytest.mark.parametrize("stem, path, value, key, allowed", [
    ("well", ("mud", "density_kgm3"), 5000.0, "mud.density_kgm3", "[500, 3000] kg/m^3"),
    ("well", ("mud", "flow_index"), 1.2, "mud.flow_index", "[0.1, 1]"),
    ("plant", ("substeps",), 0, "substeps", "[1, 100]"),
    ("plant", ("step_s",), 0.5, "step_s", "(0, 0.1] s"),
    ("actuators", ("choke", "time_constant_s"), 0.0, "choke.time_constant_s", "(0, 1000] s"),
    ("estimator", ("nis_alarm_probability",), 0.1, "nis_alarm_probability", "[0.5, 0.999999]"),
    ("estimator", ("measurement_noise", "bhp_pa"), -1.0, "measurement_noise.bhp_pa",
     "[0, 1e+07] Pa"),
    ("nmpc", ("input_span", "spp_pa"), 1.0, None, None),  # in range: loads
])
def test_out_of_range_number(cfg, stem, path, value, key, allowed):
    file = set_key(cfg, stem, path, value)
    if key is None:
        load_rig(cfg)
        return
    assert_names(load_error(cfg), str(file), key, repr(value), allowed)


def test_integer_field_refuses_fraction(cfg):
    file = set_key(cfg, "plant", ("substeps",), 2.5)
    assert_names(load_error(cfg), str(file), "substeps", "2.5", "integer", "[1, 100]")


# ------------------------------------------------------------ geometry that nests
@pytest.mark.parametrize("index, inner, outer", [(1, 0.127, 0.127), (1, 0.2, 0.127), (2, 0.18, 0.174)])
def test_inner_diameter_not_smaller_than_outer(cfg, index, inner, outer):
    file = set_key(cfg, "well", ("string", index, "inner_diameter_m"), inner)
    assert_names(load_error(cfg), str(file), f"string[{index}].inner_diameter_m", str(inner),
                 f"outer_diameter_m {outer}")


def test_tool_joint_diameters_must_nest(cfg):
    file = set_key(cfg, "well", ("string", 0, "tool_joint_inner_diameter_m"), 0.17)
    assert_names(load_error(cfg), str(file), "string[0].tool_joint_inner_diameter_m", "0.17",
                 "tool_joint_outer_diameter_m 0.1684")


def test_string_wider_than_hole(cfg):
    file = set_key(cfg, "well", ("string", 2, "outer_diameter_m"), 0.25)
    assert_names(load_error(cfg), str(file), "string[2].outer_diameter_m", "0.25",
                 "hole_diameter_m 0.245")


def test_hole_narrower_than_tool_joints(cfg):
    """The widest part of a section is its tool joint (0.1684 m) when it has one."""
    file = set_key(cfg, "well", ("hole_diameter_m",), 0.16)
    assert_names(load_error(cfg), str(file), "string[0].tool_joint_outer_diameter_m", "0.1684",
                 "hole_diameter_m 0.16")


def test_string_longer_than_well(cfg):
    file = set_key(cfg, "well", ("segment_lengths_m",), [1092.0, 1092.0, 1092.0, 100.0])
    assert_names(load_error(cfg), str(file), "string", "3607.8", "segment_lengths_m", "3376")


def test_too_few_segments(cfg):
    file = set_key(cfg, "well", ("segment_lengths_m",), [3620.1])
    assert_names(load_error(cfg), str(file), "segment_lengths_m", "3620.1", "at least 2")


# ----------------------------------------------------------------- keys and types
@pytest.mark.parametrize("stem, path, key, where, allowed", [
    ("well", ("mud", "colour"), "colour", "mud", "density_kgm3"),
    ("plant", ("step",), "step", "<top>", "step_s"),
    ("well", ("string", 1, "grade"), "grade", "string[1]", "outer_diameter_m"),
])
def test_unknown_key(cfg, stem, path, key, where, allowed):
    file = set_key(cfg, stem, path, "brown")
    assert_names(load_error(cfg), str(file), f"{where}: unknown key(s) {key}", "allowed:", allowed)


@pytest.mark.parametrize("stem, path, key, allowed", [
    ("well", ("mud", "flow_index"), "mud.flow_index", "[0.1, 1]"),
    ("well", ("string", 2, "inner_diameter_m"), "string[2].inner_diameter_m", "(0, 1] m"),
    ("well", ("turbulence",), "turbulence", "a mapping with keys string_a"),
    ("nmpc", ("solver",), "solver", "one of rti, sqpmethod, ipopt, fatrop"),
    ("estimator", ("rig_process_std",), "rig_process_std", "non-empty list"),
    ("plant", ("sensor_period_s",), "sensor_period_s", "(0, 10] s"),
])
def test_missing_key(cfg, stem, path, key, allowed):
    file = del_key(cfg, stem, path)
    assert_names(load_error(cfg), str(file), f"{key}: missing key", allowed)


def test_missing_key_with_default_is_fine(cfg):
    del_key(cfg, "estimator", ("estimate_bottom_influx",))
    del_key(cfg, "well", ("string", 0, "tool_joint_length_m"))
    rig = load_rig(cfg)
    assert rig.estimator.estimate_bottom_influx is False
    assert rig.well.string[0].tool_joint_length_m == 0.0


@pytest.mark.parametrize("stem, path, value, key, allowed", [
    # string for number (quoted numbers too: no silent conversion)
    ("well", ("mud", "density_kgm3"), "heavy", "mud.density_kgm3", "a number in [500, 3000] kg/m^3"),
    ("well", ("mud", "density_kgm3"), "1800", "mud.density_kgm3", "a number in [500, 3000] kg/m^3"),
    ("plant", ("substeps",), "two", "plant.yaml: substeps", "an integer in [1, 100]"),
    # bool for number
    ("well", ("gravity_mps2",), True, "gravity_mps2", "a number in [0, 20] m/s^2"),
    # number for bool
    ("estimator", ("estimate_bottom_influx",), 1, "estimate_bottom_influx", "true or false"),
    ("estimator", ("estimate_bottom_influx",), "yes please", "estimate_bottom_influx",
     "true or false"),
    # scalar for list
    ("well", ("segment_lengths_m",), 3620.1, "segment_lengths_m",
     "a non-empty list, each item a number in (0, 20000] m"),
    ("estimator", ("rig_process_std",), 0.001, "rig_process_std", "non-empty list"),
    ("well", ("segment_lengths_m",), [], "segment_lengths_m", "non-empty list"),
    # list / mapping for scalar, scalar for mapping, number for string
    ("well", ("hole_diameter_m",), [0.245], "hole_diameter_m", "a number in (0, 2] m"),
    ("well", ("mud",), 1800.0, "mud", "mapping"),
    ("nmpc", ("solver",), 1, "solver", "one of rti, sqpmethod, ipopt, fatrop"),
])
def test_wrong_type(cfg, stem, path, value, key, allowed):
    file = set_key(cfg, stem, path, value)
    assert_names(load_error(cfg), str(file), key, repr(value), allowed)


@pytest.mark.parametrize("stem, path, value, key, choices", [
    ("nmpc", ("solver",), "snopt", "solver", "rti, sqpmethod, ipopt, fatrop"),
    ("nmpc", ("configuration",), "nmpc1", "configuration", "NMPC0, NMPC1, NMPC2"),
    ("nmpc", ("integrator",), "rk45", "integrator", "rk4, euler"),
    ("well", ("turbulence", "annulus_model"), "colebrook", "turbulence.annulus_model",
     "dodge_metzner, power_law"),
])
def test_bad_choice(cfg, stem, path, value, key, choices):
    file = set_key(cfg, stem, path, value)
    assert_names(load_error(cfg), str(file), key, repr(value), choices)


# ------------------------------------------------------------------- non-finite
@pytest.mark.parametrize("stem, path, value, key, allowed", [
    ("well", ("mud", "density_kgm3"), math.nan, "mud.density_kgm3", "[500, 3000] kg/m^3"),
    ("well", ("hole_diameter_m",), math.inf, "hole_diameter_m", "(0, 2] m"),
    ("well", ("segment_lengths_m", 1), -math.inf, "segment_lengths_m[1]", "(0, 20000] m"),
    # no upper bound: +inf is still refused
    ("estimator", ("pressure_process_std_pa",), math.inf, "pressure_process_std_pa", "[0, inf] Pa"),
    ("estimator", ("rig_process_std", 0), math.nan, "rig_process_std[0]", "[0, inf]"),
])
def test_non_finite_number(cfg, stem, path, value, key, allowed):
    file = set_key(cfg, stem, path, value)
    text = file.read_text()
    assert ".nan" in text or ".inf" in text            # written as YAML's .nan / .inf
    assert_names(load_error(cfg), str(file), key, repr(value), allowed)


def test_non_finite_literal_in_yaml_text(cfg):
    file = cfg / "plant.yaml"
    file.write_text(file.read_text().replace("step_s: 0.01", "step_s: .NaN"), encoding="utf-8")
    assert_names(load_error(cfg), str(file), "step_s", "nan", "(0, 0.1] s")


# --------------------------------------------------------------- file problems
@pytest.mark.parametrize("text, line", [
    ("step_s: [0.01\nsubsteps: 2\n", "line"),
    ("step_s: 0.01\n\tsubsteps: 2\n", "line 2"),
    ("measurement_noise:\n  bhp_pa: 1.0e5\n bad_indent: 1\n", "line 3"),
])
def test_invalid_yaml_syntax(cfg, text, line):
    file = cfg / "plant.yaml"
    file.write_text(text, encoding="utf-8")
    assert_names(load_error(cfg), str(file), "not valid YAML", line)


def test_duplicate_key_refused(cfg):
    file = cfg / "plant.yaml"
    file.write_text(file.read_text() + "step_s: 0.02\n", encoding="utf-8")
    assert_names(load_error(cfg), str(file), "duplicate key 'step_s'")


@pytest.mark.parametrize("text, shown", [("", "None"), ("- 1\n- 2\n", "[1, 2]"), ("42\n", "42")])
def test_file_that_is_not_a_mapping(cfg, text, shown):
    file = cfg / "nmpc.yaml"
    file.write_text(text, encoding="utf-8")
    assert_names(load_error(cfg), str(file), "<top>", "expected a mapping", "Nmpc", shown)


def test_missing_file(cfg):
    file = cfg / "estimator.yaml"
    file.unlink()
    assert_names(load_error(cfg), str(file), "cannot read", "No such file")


def test_unreadable_file_is_a_directory(cfg):
    file = cfg / "actuators.yaml"
    file.unlink()
    file.mkdir()
    assert_names(load_error(cfg), str(file), "cannot read", "directory")


def test_unreadable_file_not_utf8(cfg):
    file = cfg / "well.yaml"
    file.write_bytes(b"hole_diameter_m: 0.245 \xff\xfe\n")
    assert_names(load_error(cfg), str(file), "cannot read", "UTF-8")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root reads any file")
def test_unreadable_file_no_permission(cfg):
    file = cfg / "plant.yaml"
    file.chmod(0)
    try:
        assert_names(load_error(cfg), str(file), "cannot read", "Permission denied")
    finally:
        file.chmod(0o644)


# -------------------------------------------------------------- sensor timing
@pytest.mark.parametrize("period", [0.015, 0.105, 0.0101])
def test_sensor_period_not_multiple_of_step(cfg, period):
    file = set_key(cfg, "plant", ("sensor_period_s",), period)
    assert_names(load_error(cfg), str(file), "sensor_period_s", str(period), "whole multiple",
                 "step_s 0.01")


@pytest.mark.parametrize("period, frames", [(0.2, 20), (0.01, 1), (0.3, 30)])
def test_sensor_period_multiple_of_step_accepted(cfg, period, frames):
    set_key(cfg, "plant", ("sensor_period_s",), period)
    assert load_rig(cfg).plant.steps_per_frame == frames


def test_well_control_settling_longer_than_its_interval(cfg):
    file = set_key(cfg, "protection", ("well_control", "settle_s"), 20.0)
    assert_names(load_error(cfg), str(file), "well_control.settle_s", "20.0 s",
                 "shorter than interval_s 18.0 s")


# -------------------------------------------------------------------- overrides
def test_bad_scenario_override_names_the_file(cfg):
    with pytest.raises(ConfigError) as info:
        load_rig(cfg, overrides={"nmpc": {"configuration": "NMPC9"}})
    assert_names(str(info.value), str(cfg / "nmpc.yaml"), "configuration", "'NMPC9'", "NMPC2")
    assert load_rig(cfg, overrides={"nmpc": {"configuration": "NMPC2"}}).nmpc.configuration == "NMPC2"


# ------------------------------------------------------------- choke and MPD controller
def test_pressure_controlled_choke_needs_its_set_point_limits(cfg):
    file = cfg / "nmpc.yaml"
    data = yaml.safe_load(file.read_text())
    data["choke_control"] = "pressure"
    del data["choke_dp_setpoint"]
    file.write_text(yaml.safe_dump(data), encoding="utf-8")
    assert_names(load_error(cfg), str(file), "choke_dp_setpoint", "choke_control pressure")


@pytest.mark.parametrize("stem, path, value, words", [
    ("nmpc", ("choke_control",), "valve", ("choke_control", "'valve'", "flow", "pressure")),
    ("nmpc", ("choke_dp_setpoint", "time_constant_s"), 0.0, ("time_constant_s", "(0, 60]")),
    ("automated_mpd", ("trim_time_constant_s",), -1.0, ("trim_time_constant_s", "-1")),
    ("automated_mpd", ("feedforward_lead_s",), 45.0, ("feedforward_lead_s", "[0, 30]")),
    ("actuators", ("choke_pressure_scale_pa",), 0.0, ("choke_pressure_scale_pa",)),
])
def test_bad_controller_values_name_the_key_and_range(cfg, stem, path, value, words):
    file = set_key(cfg, stem, path, value)
    assert_names(load_error(cfg), str(file), *words)


def test_shipped_controllers_choke_inputs(cfg):
    """The NMPC plans the choke flow (docs/nmpc.md section 9), automated MPD drives the
    choke's pressure loop."""
    rig = load_rig(cfg)
    assert rig.nmpc.choke_control == "flow" and rig.nmpc.block_reference == "profile"
    assert rig.automated_mpd.acceleration_mps2 <= rig.protection.trip_acceleration_max_mps2
    assert rig.actuators.choke_pressure_kp > 0.0
