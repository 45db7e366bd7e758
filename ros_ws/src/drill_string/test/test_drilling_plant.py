"""The drilling graph's plain core: the scenario and config/drilling.yaml (validation, the
driller's schedule), the top drive's and block feed's lag, the plant frame by frame (the
same steps as one simulate(), the measured channels, a bad frame held), the hook load and
the SI top-drive input of the simulator, and the messages that mirror them."""
from pathlib import Path

import numpy as np
import pytest
from drill_core.rig_root import rig_root
from drill_msgs.msg import DownholeMeasurement, DrillingTruth, SurfaceMeasurement

from drill_core.config import ConfigError, Lag
from drill_string import DrillStringSimulator, paper_fig9_config, simulate
from drill_string.drives import SpeedDrive
from drill_string.lumped_model import axial_system, buoyed_weight_n
from drill_string.parameters import rpm_to_rad_s
from drill_string.plant import (DOWNHOLE_CHANNELS, SURFACE_CHANNELS, DrillingPlant,
                                plant_step_s)
from drill_string.scenario import load_drilling_scenario
from drill_string.simulate import DEFAULT_SCALED_STEP, TRAJECTORY_FIELDS

ROOT = rig_root()
CONFIG = ROOT / "config"
SCENARIOS = ROOT / "config" / "scenarios"
LAG = Lag(time_constant_s=0.5, minimum=0.0, maximum=26.0, rate_limit_per_s=2.0)


def _scenario(tmp_path, text: str) -> Path:
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return path


BASE = """kind: drilling
name: t
description: t
duration_s: 3.0
seed: 1
string: {section: 12.25in, n_elements: 6, with_bha: true, mud_viscosity_pa_s: 0.03}
initial: {top_drive_rpm: 160.0, block_speed_m_s: 0.05, bit_axial_speed_m_s: 0.13971}
"""


# ---- scenario and configuration -------------------------------------------------------------
@pytest.mark.parametrize("name", ["drilling_12in_op1", "drilling_12in_op2", "drilling_36in"])
def test_the_drilling_scenarios_load(name):
    scenario, rig = load_drilling_scenario(SCENARIOS / f"{name}.yaml", CONFIG)
    assert scenario.name == name
    frames = scenario.duration_s / rig.sensor_period_s
    assert frames == pytest.approx(round(frames)), "whole frames"


def test_op1_is_the_papers_fig9_set_up():
    scenario, _ = load_drilling_scenario(SCENARIOS / "drilling_12in_op1.yaml", CONFIG)
    mine, paper = scenario.drilling_config(), paper_fig9_config(120.0)
    assert mine.initial_bit_axial_speed_m_s == pytest.approx(paper.initial_bit_axial_speed_m_s,
                                                             rel=1e-4)
    assert mine == paper.__class__(**{**paper.__dict__, "initial_bit_axial_speed_m_s":
                                      mine.initial_bit_axial_speed_m_s})


@pytest.mark.parametrize("extra, key", [
    ("evaluate_from_s: 3.0\n", "evaluate_from_s"),
    ("overrides: {plant: {step_s: 0.1}}\n", "overrides"),
    ("overrides: {drilling: {actuator_step_s: 0.03}}\n", "sensor_period_s"),
    ("overrides: {drilling: {top_drive: {minimum: -1.0}}}\n", "top_drive.minimum"),
    ("schedule: [{time_s: 2.0}, {time_s: 1.0}]\n", "schedule"),
])
def test_bad_drilling_scenarios_are_refused_naming_the_key(tmp_path, extra, key):
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        load_drilling_scenario(_scenario(tmp_path, BASE + extra), CONFIG)


def test_the_driller_follows_its_schedule(tmp_path):
    path = _scenario(tmp_path, BASE + "schedule: [{time_s: 1.0, top_drive_rpm: 120.0}, "
                                      "{time_s: 2.0, block_speed_m_s: 0.0}]\n")
    scenario, _ = load_drilling_scenario(path, CONFIG)
    assert scenario.speeds_at(0.5) == scenario.start_speeds == (rpm_to_rad_s(160.0), 0.05)
    assert scenario.speeds_at(1.0) == (rpm_to_rad_s(120.0), 0.05)
    assert scenario.speeds_at(2.5) == (rpm_to_rad_s(120.0), 0.0)


# ---- the drives ---------------------------------------------------------------------------------
def test_a_drive_at_its_command_holds_it_exactly():
    out = SpeedDrive(LAG, 12.5).frame(12.5, 0.01, 10)
    assert np.all(out.output == 12.5)


def test_a_drive_lags_its_command_first_order():
    lag = Lag(time_constant_s=0.5, minimum=0.0, maximum=26.0, rate_limit_per_s=100.0)
    drive = SpeedDrive(lag, 10.0)
    out = np.concatenate([drive.frame(12.0, 0.01, 10).output for _ in range(10)])
    t = np.arange(100) * 0.01
    assert out == pytest.approx(12.0 - 2.0 * np.exp(-t / 0.5), abs=1e-12)


def test_a_drive_keeps_its_rate_and_range_limits_and_holds_on_a_bad_command():
    drive = SpeedDrive(LAG, 0.0)
    out = drive.frame(100.0, 0.01, 100).output
    assert drive.command == 26.0                       # clamped to the range
    assert np.max(np.diff(out)) == pytest.approx(2.0 * 0.01)    # 2 rad/s^2
    held = drive.frame(float("nan"), 0.01, 10)
    assert held.command == 26.0 and np.isnan(held.reference)
    assert np.all(np.diff(held.output) > 0.0)          # still on its way to the last command


# ---- the simulator's additions ----------------------------------------------------------------
def test_the_hook_load_carries_the_string_less_the_bit_and_the_drag():
    cfg = paper_fig9_config(160.0, initial_bit_axial_speed_m_s=0.0)
    sim = DrillStringSimulator(cfg)
    start = sim.sample()
    p = cfg.parameters()
    drag_n = float(np.sum(np.diag(axial_system(p.section, p.n, p.with_bha).damping))) * 0.05
    expected = buoyed_weight_n(p) - start.meta["nominal_wob_n"] - drag_n
    assert start.hook_load_n[0] == pytest.approx(expected, rel=2e-4)   # per-block vs top drag
    assert buoyed_weight_n(p) == pytest.approx(1.267e6, rel=1e-3)
    run = sim.advance(2.0)
    assert run.hook_load_n == pytest.approx(start.hook_load_n[0], rel=1e-9)   # steady state
    assert run.block_position_m[-1] == pytest.approx(0.05 * run.time_s[-1], rel=1e-12)


def test_the_top_drive_speed_in_rad_s_is_the_one_in_rpm():
    cfg = paper_fig9_config(120.0)
    a, b = DrillStringSimulator(cfg), DrillStringSimulator(cfg)
    ra = a.advance(1.0, top_drive_rpm=150.0)
    rb = b.advance(1.0, top_drive_rad_s=rpm_to_rad_s(150.0))
    assert np.array_equal(ra.bit_speed_rad_s, rb.bit_speed_rad_s)
    assert ra.top_drive_speed_rad_s == pytest.approx(rpm_to_rad_s(150.0))
    with pytest.raises(ValueError, match="not both"):
        a.advance(0.1, top_drive_rpm=150.0, top_drive_rad_s=15.0)


# ---- the plant, frame by frame ------------------------------------------------------------------
def test_the_plant_step_divides_the_actuator_step():
    t_star = paper_fig9_config(120.0).parameters().t_star_s
    step = plant_step_s(0.01, t_star)
    assert step <= DEFAULT_SCALED_STEP * t_star and 0.01 / step == pytest.approx(6)
    assert plant_step_s(DEFAULT_SCALED_STEP * t_star, t_star) == pytest.approx(
        DEFAULT_SCALED_STEP * t_star)


def _plant(tmp_path, noise: bool = False):
    extra = "" if noise else "overrides: {drilling: {measurement_noise: {" + ", ".join(
        f"{c}: 0.0" for c in (*SURFACE_CHANNELS, *DOWNHOLE_CHANNELS)) + "}}}\n"
    scenario, rig = load_drilling_scenario(_scenario(tmp_path, BASE + "evaluate_from_s: 1.0\n"
                                                     + extra), CONFIG)
    return DrillingPlant(scenario, rig, seed=3), scenario, rig


def test_the_frames_are_the_steps_of_one_simulation(tmp_path):
    plant, scenario, rig = _plant(tmp_path)
    start = scenario.start_speeds
    frames = []
    for _ in range(int(round(scenario.duration_s / rig.sensor_period_s))):
        assert plant.advance(np.full(10, start.top_drive_rad_s),
                             np.full(10, start.block_speed_m_s)) == []
        frames.append((plant.evaluated, plant.steps))
    config = scenario.drilling_config()
    ref = simulate(config, 3.0, plant_step_s(0.01, config.parameters().t_star_s))
    steps = np.concatenate([s.bit_speed_rad_s for _, s in frames])
    assert np.array_equal(steps, ref.bit_speed_rad_s)
    first = next(s for e, s in frames if e)
    assert [e for e, _ in frames].count(False) == 10 and first.time_s[0] > 1.0


def test_a_bad_frame_holds_the_drives_last_input(tmp_path):
    plant, scenario, _ = _plant(tmp_path)
    start = scenario.start_speeds
    bad = plant.advance(np.full(10, np.nan), np.full(9, start.block_speed_m_s))
    assert bad == ["top_drive", "block_feed"]
    assert plant.steps.top_drive_speed_rad_s == pytest.approx(start.top_drive_rad_s, rel=1e-12)


def test_the_sensors_read_frame_means_and_end_values(tmp_path):
    plant, scenario, _ = _plant(tmp_path)
    initial = plant.sensors(DOWNHOLE_CHANNELS)
    assert initial["bit_depth_m"] == 0.0
    assert initial["wob_n"] == pytest.approx(plant.sim.sample().wob_n[0])
    start = scenario.start_speeds
    plant.advance(np.full(10, start.top_drive_rad_s), np.full(10, 0.2))
    down, surface = plant.sensors(DOWNHOLE_CHANNELS), plant.sensors(SURFACE_CHANNELS)
    assert down["wob_n"] == pytest.approx(np.mean(plant.steps.wob_n))
    assert down["bit_depth_m"] == plant.steps.bit_depth_m[-1]
    assert surface["block_position_m"] == pytest.approx(0.2 * 0.1)


def test_sensor_noise_is_drawn_from_the_seed(tmp_path):
    a, _, _ = _plant(tmp_path, noise=True)
    b, _, _ = _plant(tmp_path, noise=True)
    first, again = a.sensors(SURFACE_CHANNELS), b.sensors(SURFACE_CHANNELS)
    assert first == again
    assert first["hook_load_n"] != pytest.approx(a.sim.sample().hook_load_n[0], abs=1.0)


def test_the_messages_mirror_the_core():
    assert set(DrillingTruth.get_fields_and_field_types()) == {"header", "evaluated",
                                                              *TRAJECTORY_FIELDS}
    assert set(SurfaceMeasurement.get_fields_and_field_types()) == {"header", *SURFACE_CHANNELS}
    assert set(DownholeMeasurement.get_fields_and_field_types()) == {"header",
                                                                    *DOWNHOLE_CHANNELS}
