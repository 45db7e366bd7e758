"""Plant-model mismatch (drill_core.mismatch): the suite, what a mismatch changes, the
seeded draws, the washed-out hole and a scenario's truth section."""
import dataclasses

import numpy as np
import pytest

from drill_core.config import ConfigError, load_rig
from drill_core.mismatch import (Mismatch, draw, load_suite, mismatch_from, read_truth_file,
                                 resolve, truth_config, write_truth_file)
from drill_core.rig_root import config_dir
from drill_core.scenario import load_scenario, scenario_truth, without_truth
from drill_core.well import build_geometry, circle_area

CONFIG = config_dir()


@pytest.fixture(scope="module")
def model():
    return load_rig(CONFIG)


def test_suite_spans_single_parameters_and_combinations_both_ways():
    members, described, _ = load_suite(CONFIG)
    assert len(members) >= 8 and set(described) == set(members)
    singles = [m for m in members.values() if len(m.changes()) == 1]
    combined = [m for m in members.values() if len(m.changes()) > 2]
    assert len(singles) >= 6 and len(combined) >= 2
    density = [m.density_factor for m in members.values()]
    assert min(density) < 1.0 < max(density)


def test_truth_config_scales_the_plants_mud_and_choke_only(model):
    m = Mismatch(density_factor=1.008, yield_stress_factor=1.25, consistency_factor=1.3,
                 flow_index_offset=-0.03, bulk_modulus_factor=0.85, choke_coefficient_factor=0.92,
                 sensor_noise_factor=2.0)
    truth = truth_config(model, m)
    mud, own = truth.well.mud, model.well.mud
    assert mud.density_kgm3 == pytest.approx(1800.0 * 1.008)
    assert mud.yield_stress_pa == pytest.approx(15.0 * 1.25)
    assert mud.annulus_yield_stress_pa == pytest.approx(15.0 * 1.25)
    assert mud.consistency_pa_sn == pytest.approx(0.15 * 1.3)
    assert mud.flow_index == pytest.approx(0.76)
    assert mud.bulk_modulus_pa == pytest.approx(6.5e9 * 0.85)
    assert truth.well.choke_coefficient_m2 == pytest.approx(0.0016 * 0.92)
    assert truth.plant.measurement_noise.bhp_pa == pytest.approx(2.0e5)
    assert (truth.estimator, truth.nmpc, truth.protection) == \
        (model.estimator, model.nmpc, model.protection)
    assert own.density_kgm3 == 1800.0          # the model's config is untouched


def test_model_mismatch_is_no_change(model):
    assert Mismatch().is_model
    assert truth_config(model, Mismatch()) == dataclasses.replace(
        model, plant=dataclasses.replace(model.plant))


def test_washout_widens_the_segments_volume_by_the_annulus_area(model):
    m = Mismatch(hole_diameter_factors=(1.0, 1.0, 1.06, 1.06))
    g0 = build_geometry(model.well)
    g1 = build_geometry(truth_config(model, m).well)
    d, length = model.well.hole_diameter_m, model.well.segment_lengths_m[2]
    added = (circle_area(1.06 * d) - circle_area(d)) * length
    assert g1.annulus_volume_m3[2] - g0.annulus_volume_m3[2] == pytest.approx(added, rel=1e-9)
    assert g1.annulus_volume_m3[:2] == g0.annulus_volume_m3[:2]
    assert g1.main_flow_area_m2[2] > g0.main_flow_area_m2[2]


def test_bad_mismatch_names_the_key_and_range(model):
    with pytest.raises(ConfigError, match=r"density_factor.*\[0.8, 1.2\]"):
        mismatch_from({"density_factor": 1.5})
    with pytest.raises(ConfigError, match="unknown key"):
        mismatch_from({"viscosity_factor": 1.1})
    with pytest.raises(ConfigError, match="hole_diameter_factors"):
        truth_config(model, Mismatch(hole_diameter_factors=(1.1, 1.1)))
    with pytest.raises(ConfigError, match="not a member"):
        resolve("no_such_member", CONFIG)


def test_draws_are_reproducible_and_spread():
    draws = load_suite(CONFIG)[2]
    first = [draw(draws, i) for i in range(20)]
    assert first == [draw(draws, i) for i in range(20)]
    density = np.array([m.density_factor for m in first])
    assert len(set(density)) == 20
    assert np.all(np.abs(density - 1.0) <= 2.5 * draws.density_factor.sd + 1e-12)
    assert resolve("draw:3", CONFIG) == ("draw:3", first[3])


def test_truth_file_round_trip(tmp_path):
    name, m = resolve("thick_report", CONFIG)
    write_truth_file(tmp_path / "truth.json", name, m)
    assert read_truth_file(tmp_path / "truth.json") == (name, m)


def test_scenario_truth_is_read_apart_from_the_scenario(tmp_path):
    text = (CONFIG / "scenarios" / "short_trip.yaml").read_text()
    path = tmp_path / "s.yaml"
    path.write_text(text + "\ntruth: yield_high\n")
    assert scenario_truth(path, CONFIG) == resolve("yield_high", CONFIG)
    assert "truth" not in without_truth(path)
    scenario, _ = load_scenario(path)
    assert scenario == load_scenario(CONFIG / "scenarios" / "short_trip.yaml")[0]
    path.write_text(text + "\ntruth: {density_factor: 1.004}\n")
    assert scenario_truth(path, CONFIG)[1] == Mismatch(density_factor=1.004)
    assert scenario_truth(CONFIG / "scenarios" / "short_trip.yaml", CONFIG) is None


def test_density_offset_state_balances_a_heavier_mud_column(model):
    """A static column of mud 14.4 kg/m^3 heavier than the report is at rest in the
    estimation model with that density offset (every annulus path's momentum balance is
    zero) and accelerates by delta_rho g dD / M without it."""
    from drill_core.backend import NUMPY
    from drill_core.estimation_model import build_estimation_model, drift
    em = build_estimation_model(model)
    assert em.with_density_offset
    g, w = em.wm.geometry, em.wm.well
    rho_true = w.mud.density_kgm3 + 14.4
    x = np.zeros(em.size)
    for i in range(1, em.n + 1):
        x[em.pressure(i)] = 1.0e6 + rho_true * w.gravity_mps2 * g.node_depth_m[i - 1]
    for i in range(2, em.n + 1):
        x[em.theta(i)] = 1.0
    u = [0.0, 0.0, 0.0, 0.0]
    for offset, balanced in ((14.4, True), (0.0, False)):
        x[em.density_offset] = offset
        rates = drift(NUMPY, em, list(x), u)
        for i in range(2, em.n + 1):
            expected = 0.0 if balanced else 14.4 * w.gravity_mps2 * (
                g.node_depth_m[i - 1] - g.node_depth_m[i - 2]) / g.annulus_inertance_kg_m4[i - 2]
            assert float(rates[em.flow(i)]) == pytest.approx(expected, abs=1e-9)


def test_string_friction_factor_scales_the_strings_friction_in_its_momentum_balance(model):
    """dq_d/dt with theta_s = 1.2 is 0.2 F_s(q_d)/M_I below its value with theta_s = 1."""
    from drill_core import hydraulics as hy
    from drill_core.backend import NUMPY
    from drill_core.config import replace
    from drill_core.estimation_model import build_estimation_model, drift
    config = dataclasses.replace(model, estimator=replace(model.estimator,
                                                          estimate_string_friction=True))
    em = build_estimation_model(config)
    x = np.zeros(em.size)
    q = 1000.0 / 60000.0
    x[em.string_flow] = q
    x[em.string_pressure] = 3.0e7
    rates = []
    for factor in (1.0, 1.2):
        x[em.string_friction] = factor
        rates.append(float(drift(NUMPY, em, list(x), [0.0, 0.0, 0.0, 1.2e7])[em.string_flow]))
    friction = float(hy.string_friction(NUMPY, em.wm, q, 0.0))
    assert rates[0] - rates[1] == pytest.approx(
        0.2 * friction / em.wm.geometry.string_inertance_kg_m4, rel=1e-9)
