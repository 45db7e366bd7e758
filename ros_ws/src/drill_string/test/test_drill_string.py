"""Drilling-mode core (drill_string) against independent numbers: Tengesdal (2021), Paper IV
Tables 2-3 and section 4.2, the continuum rod of the thesis' section 2.2.8, the analytic
steady state of section 2.4, the decoupled delay equation (43) integrated on its own, and
the stick-slip behaviour of Fig. 9 (OP1 sticks, OP2 does not)."""
import math
import time

import numpy as np
import pytest
from matplotlib.figure import Figure

from drill_string import (DrillingConfig, DrillStringSimulator, axial_stability, derive,
                          longest_stick_s, paper_fig9_config, rate_of_penetration_m_s, simulate,
                          stick_slip_severity, stick_time_fraction)
from drill_string.bit_rock import SiBitRock
from drill_string.convergence import convergence_study
from drill_string.lumped_model import (SecondOrderSystem, axial_system, chain_stiffness,
                                       continuum_fixed_free_rad_s, scaled_axial_matrices,
                                       scaled_axial_eigenfrequencies, steady_state,
                                       torsional_system, uniform_chain_rad_s)
from drill_string.parameters import INCH_M, Steel, polar_moment_m4, rpm_to_rad_s, section
from drill_string.stability import (characteristic_polynomials, modal_data, root_velocity)
from drill_string.stability_report import (critical_speed_figure, critical_speed_table,
                                           critical_speeds, crossing_table)


# ---- Table 1 and the derived Tables 2-3 ------------------------------------------------------
def test_table1_drill_pipe_area_matches_its_diameters():
    sec = section("12.25in")
    annulus = math.pi / 4 * (sec.dp_od_m ** 2 - sec.dp_id_m ** 2)
    assert annulus == pytest.approx(sec.dp_area_m2, rel=2e-3)
    assert sec.hole_diameter_m == pytest.approx(12.25 * INCH_M)
    assert section("36in").string_length_m == 200.0


# Paper IV Table 2 (n = 2) and Table 3 (12 1/4", n = 6 with BHA), with t* from Table 2.
PRINTED = {
    ("36in", 2, False): dict(t_star=0.0629, d_hat=1.549e-5, c_hat=1.954e-5, nb_alpha=119.0,
                             n2_cbar2=10.09, torque_gain=1996),
    ("12.25in", 2, False): dict(t_star=0.716, d_hat=0.01987, c_hat=0.008163, nb_alpha=460.7,
                                n2_cbar2=10.09, torque_gain=2629),
    ("12.25in", 6, True): dict(t_star=0.716, d_hat=0.01987, c_hat=0.008163, nb_alpha=926.5,
                               n2_cbar2=90.79, torque_gain=4380),
}


@pytest.mark.parametrize("key", list(PRINTED))
def test_derived_parameters_reproduce_tables_2_and_3(key):
    p = derive(*key)
    row = p.table_row()
    want = PRINTED[key]
    assert p.t_star_s == pytest.approx(want["t_star"], rel=1e-3)
    for name in ("d_hat", "c_hat", "nb_alpha", "n2_cbar2", "torque_gain"):
        assert row[name] == pytest.approx(want[name], rel=1e-3), name
    assert row["lambda"] == pytest.approx(0.001538, rel=1e-3)
    assert row["beta"] == pytest.approx(0.1950, rel=1e-3)


def test_scaled_operating_points_match_the_paper():
    p12 = derive("12.25in", 6, True)
    assert p12.scaled_speed(rpm_to_rad_s(120)) == pytest.approx(8.995, abs=1e-3)   # OP1
    assert p12.scaled_speed(rpm_to_rad_s(160)) == pytest.approx(11.99, abs=1e-2)   # OP2
    assert p12.scaled_rate(0.05) == pytest.approx(0.0358, abs=1e-4)
    p36 = derive("36in", 2)
    assert p36.scaled_speed(5 * math.pi) == pytest.approx(0.98, abs=0.01)
    assert p36.scaled_rate(0.05) == pytest.approx(0.0031, abs=1e-4)


# ---- lumped model against the continuum ------------------------------------------------------
def test_thesis_table_2_1_lumped_torsional_pendulum():
    """Thesis section 2.2.8, Table 2.1 (J = 1 m^4, L = 1000 m, rho = 8000 kg/m3; the printed
    frequencies need G = 80 GPa)."""
    g, rho, length = 80e9, 8000.0, 1000.0
    got = []
    for n in (2, 10, 100):
        h = length / n
        sys = SecondOrderSystem(np.eye(n) * rho * h, np.zeros((n, n)),
                                chain_stiffness(np.full(n, g / h)))
        got.append(sys.eigenfrequencies_rad_s()[0])
    assert np.round(got, 2).tolist() == [3.91, 4.73, 4.94]
    assert continuum_fixed_free_rad_s(math.sqrt(g / rho), length, 1)[0] == pytest.approx(
        4.97, abs=5e-3)


@pytest.mark.parametrize("domain", ["axial", "torsional"])
def test_lumped_frequencies_approach_the_continuum_rod(domain):
    sec, steel = section("12.25in"), Steel()
    speed = steel.axial_wave_speed_m_s if domain == "axial" else steel.torsional_wave_speed_m_s
    build = axial_system if domain == "axial" else torsional_system
    exact = continuum_fixed_free_rad_s(speed, sec.string_length_m, 3)
    errors = []
    for n in (2, 5, 20, 80, 320):
        lumped = build(sec, n).eigenfrequencies_rad_s()
        assert lumped == pytest.approx(uniform_chain_rad_s(speed, sec.string_length_m, n),
                                       rel=1e-9)
        errors.append(abs(lumped[0] - exact[0]) / exact[0])
        assert np.all(lumped[:min(n, 3)] < exact[:min(n, 3)])   # lumping under-estimates
    assert all(a > b for a, b in zip(errors, errors[1:]))
    # this lumping (a full block at the free end) converges as 1/n: 4x n, 1/4 the error
    assert errors[-2] / errors[-1] == pytest.approx(4.0, rel=0.02)
    assert build(sec, 320).eigenfrequencies_rad_s()[:3] == pytest.approx(exact, rel=2e-3)


def test_scaled_axial_eigenfrequencies_36in_n2():
    assert scaled_axial_eigenfrequencies(derive("36in", 2)) == pytest.approx(
        [5.1392, 1.9630], abs=1e-4)


# ---- steady state (section 2.4) --------------------------------------------------------------
def test_analytic_steady_state_solves_the_si_equations():
    p = derive("12.25in", 6, True)
    v0, om0 = 0.05, rpm_to_rad_s(140)
    ss = steady_state(p, v0, om0)
    coeff = SiBitRock.of(p)
    assert ss.depth_of_cut_m == pytest.approx(2 * math.pi * v0 / (6 * om0), rel=1e-12)
    assert ss.wob_n == pytest.approx(coeff.k_c_n_m * ss.depth_of_cut_m + coeff.k_f_n)
    ax, to = axial_system(p.section, 6, True), torsional_system(p.section, 6, True)
    t1, t2 = np.eye(6)[0], np.eye(6)[-1]
    k1 = ax.stiffness[0, 0] + ax.stiffness[0, 1]        # spring to the travelling block
    kappa1 = to.stiffness[0, 0] + to.stiffness[0, 1]    # spring to the top drive
    for t in (0.0, 3.7, 100.0):          # rigid-body drift V0 t on top of y*, eqs. (15)-(19)
        y, phi = v0 * t + ss.axial_offset_m, om0 * t + ss.angle_offset_rad
        res_ax = ax.damping @ np.full(6, v0) + ax.stiffness @ y - t1 * k1 * v0 * t \
            + t2 * ss.wob_n
        res_to = to.damping @ np.full(6, om0) + to.stiffness @ phi - t1 * kappa1 * om0 * t \
            + t2 * ss.tob_nm
        assert np.max(np.abs(res_ax)) < 1e-6 * ss.wob_n
        assert np.max(np.abs(res_to)) < 1e-6 * ss.tob_nm
    # eq. (17): the bit spring carries the WOB (plus the bit block's own drag)
    k_n = -ax.stiffness[-1, -2]
    spring = k_n * (ss.axial_offset_m[-2] - ss.axial_offset_m[-1])
    assert spring - ax.damping[-1, -1] * v0 == pytest.approx(ss.wob_n, rel=1e-9)


@pytest.mark.parametrize("scheme", ["newmark", "generalized_alpha", "rk4"])
def test_steady_state_is_an_equilibrium_of_the_simulated_model(scheme):
    cfg = DrillingConfig(section="12.25in", n_elements=6, with_bha=True, top_drive_rpm=160,
                         block_speed_m_s=0.05, mud_viscosity_pa_s=0.03, scheme=scheme)
    p = cfg.parameters()
    ss = steady_state(p, 0.05, rpm_to_rad_s(160))
    tr = simulate(cfg, 5.0)
    assert tr.bit_speed_rad_s == pytest.approx(rpm_to_rad_s(160), rel=1e-9)
    assert tr.bit_axial_speed_m_s == pytest.approx(0.05, rel=1e-9)
    assert tr.wob_n == pytest.approx(ss.wob_n, rel=1e-9)
    assert tr.tob_nm == pytest.approx(ss.tob_nm, rel=1e-9)
    assert tr.depth_of_cut_m == pytest.approx(ss.depth_of_cut_m, rel=1e-9)
    assert tr.delay_s == pytest.approx(ss.delay_s, rel=1e-9)
    assert rate_of_penetration_m_s(tr) == pytest.approx(0.05, rel=1e-9)
    assert stick_slip_severity(tr) < 1e-9 and stick_time_fraction(tr) == 0.0


# ---- decoupled axial stability (section 3.1, numbers of section 4.2) -------------------------
def test_walton_marshall_reproduces_the_36in_n2_numbers():
    r = axial_stability("36in", 2)
    assert r.d_hat == pytest.approx(1.55e-5, rel=5e-3)
    assert r.eigenfrequencies == pytest.approx([5.1392, 1.9630], abs=1e-4)
    assert r.crossing_frequencies == pytest.approx([15.7675, 5.1392, 4.442, 1.9630], abs=1e-4)
    assert r.directions.tolist() == [1, -1, 1, -1]
    # "omega_1* is repeated several times before a stabilising switch"
    first = [s.direction for s in r.switches[:4]]
    assert r.switches[0].frequency == pytest.approx(15.7675, abs=1e-4)
    assert first[:3] == [1, 1, 1]
    assert r.delay_margin == pytest.approx(r.switches[0].delay)
    assert r.stable_delay_intervals == ((0.0, r.delay_margin),)


@pytest.mark.parametrize("key", [("36in", 2, False), ("36in", 3, False), ("12.25in", 3, True)])
def test_crossing_frequencies_agree_with_the_expanded_polynomial(key):
    p = derive(*key)
    _, _, f = characteristic_polynomials(p)
    roots = np.roots(f[::-1])
    positive = np.sort(roots[(np.abs(roots.imag) < 1e-6 * np.abs(roots)) & (roots.real > 0)]
                       .real)[::-1]
    r = axial_stability(*key)
    assert r.crossing_frequencies == pytest.approx(positive, rel=1e-6)


@pytest.mark.parametrize("key", [("36in", 2, False), ("12.25in", 6, True)])
def test_crossing_directions_agree_with_the_roots_motion(key):
    p = derive(*key)
    om, wt = modal_data(p)
    r = axial_stability(*key)
    for sw in r.switches[:12]:
        s_dot = root_velocity(sw.frequency, sw.delay, om, wt, p.d_hat, p.nb_alpha)
        assert np.sign(s_dot.real) == sw.direction


def test_single_block_case_is_equation_42():
    p = derive("12.25in", 1)
    r = axial_stability("12.25in", 1)
    assert r.eigenfrequencies[0] == pytest.approx(p.c_bar, rel=1e-12)     # omega_1 = c_bar
    gain = 6 * p.section.string_length_m * p.section.bit_radius_m * 45e6 * 0.65 \
        / (p.steel.shear_modulus_pa * p.section.dp_area_m2)
    for sw in r.switches[:6]:
        s = 1j * sw.frequency
        char = s * s + p.d_hat * s + p.c_bar ** 2 + gain * (1 - np.exp(-sw.delay * s))
        assert abs(char) < 1e-8 * p.c_bar ** 2


def _decoupled_growth(p, rpm, duration=40.0, h=4e-3):
    """Integrate eq. (43) on its own (RK4, constant delay on the step grid) from the initial
    bit speed 0.1 of Fig. 8; returns late / early peak bit speed."""
    m, c, k = scaled_axial_matrices(p)
    minv = 1.0 / np.diag(m)
    delay = 2 * math.pi / (6 * p.scaled_speed(rpm_to_rad_s(rpm)))
    lag = max(1, int(round(delay / h)))
    h = delay / lag
    steps = int(duration / h)
    z, v = np.zeros(p.n), np.zeros(p.n)
    v[-1] = 0.1
    past = np.zeros(steps + lag + 1)

    def f(z, v, zd):
        a = -(c @ v + k @ z) * minv
        a[-1] += p.nb_alpha * (zd - z[-1]) * minv[-1]
        return v, a

    peak = np.empty(steps)
    for i in range(steps):
        d0, d1 = past[i], past[i + 1]
        dm = 0.5 * (d0 + d1)
        k1 = f(z, v, d0)
        k2 = f(z + h / 2 * k1[0], v + h / 2 * k1[1], dm)
        k3 = f(z + h / 2 * k2[0], v + h / 2 * k2[1], dm)
        k4 = f(z + h * k3[0], v + h * k3[1], d1)
        z = z + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        v = v + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        past[lag + i + 1] = z[-1]
        peak[i] = abs(v[-1])
    q = steps // 4
    return peak[-q:].max() / peak[q:2 * q].max()


@pytest.mark.parametrize("key", [("36in", 2, False), ("12.25in", 6, True)])
def test_delay_margin_separates_growing_from_decaying_axial_motion(key):
    p = derive(*key)
    crit = axial_stability(*key).critical_speed_rpm
    assert _decoupled_growth(p, 0.85 * crit) > 2.0
    assert _decoupled_growth(p, 1.15 * crit) < 0.5


def test_critical_speed_rises_with_n_and_150_rpm_is_stable_for_12in_n2():
    # section 5.2: 150 rpm is a stable speed for 12 1/4" in the decoupled analysis (Fig. 3)
    assert axial_stability("12.25in", 2).is_stable_at(150.0)
    assert not axial_stability("12.25in", 2).is_stable_at(100.0)
    for name in ("36in", "12.25in", "6in"):
        rpm = [axial_stability(name, n).critical_speed_rpm for n in (1, 2, 4, 8, 12)]
        assert all(a < b for a, b in zip(rpm, rpm[1:])), (name, rpm)


def test_fig7_operating_points_in_the_decoupled_analysis():
    r = axial_stability("12.25in", 6, True, mud_viscosity_pa_s=0.03)
    assert not r.is_stable_at(120.0)     # OP1
    assert r.is_stable_at(160.0)         # OP2


# ---- coupled simulation (section 5) ----------------------------------------------------------
@pytest.fixture(scope="module")
def fig9():
    runs = {}
    for name, rpm in (("OP1", 120.0), ("OP2", 160.0)):
        cfg = paper_fig9_config(rpm)
        t_star = cfg.parameters().t_star_s
        start = time.process_time()       # CPU time: robust to other load on the machine
        tr = simulate(cfg, 100 * t_star)
        runs[name] = (tr, t_star, time.process_time() - start)
    return runs


def test_op1_develops_sustained_stick_slip(fig9):
    tr, t_star, _ = fig9["OP1"]
    late = 65 * t_star
    assert stick_time_fraction(tr, late) > 0.1
    assert stick_slip_severity(tr, late) > 1.5
    assert 1.5 * t_star < longest_stick_s(tr, late) < 5 * t_star    # paper: about 3 t*
    assert stick_time_fraction(tr.window(0.0, 40 * t_star)) == 0.0  # slow build-up first


def test_op2_has_no_stick_but_growing_oscillation(fig9):
    tr, t_star, _ = fig9["OP2"]
    assert stick_time_fraction(tr) == 0.0
    early = stick_slip_severity(tr.window(10 * t_star, 40 * t_star))
    late = stick_slip_severity(tr.window(70 * t_star, 100 * t_star))
    assert 0.1 < early < late < 1.0
    assert rate_of_penetration_m_s(tr, 10 * t_star) == pytest.approx(0.05, rel=0.05)


def test_stick_rules_hold_along_op1(fig9):
    tr, _, _ = fig9["OP1"]
    assert np.min(tr.bit_speed_rad_s[~tr.off_bottom]) > -1e-9   # on bottom: never backwards
    stuck = tr.torsional_stick & ~tr.off_bottom
    assert stuck.sum() > 100
    assert np.max(np.abs(tr.bit_speed_rad_s[stuck])) < 1e-9
    assert np.max(tr.bit_axial_speed_m_s[stuck]) < 1e-9       # no advance while stuck
    assert np.all(tr.wob_n >= 0.0)


def test_delay_is_one_blade_of_bit_rotation(fig9):
    tr, _, _ = fig9["OP1"]
    t, w = tr.time_s, tr.bit_speed_rad_s
    angle = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(t))])
    blade = 2 * math.pi / 6
    for i in range(2000, t.size, 4001):
        past = np.interp(t[i] - tr.delay_s[i], t, angle)
        assert angle[i] - past == pytest.approx(blade, abs=2e-3 * blade)


def test_simulation_runs_much_faster_than_real_time(fig9):
    for name in ("OP1", "OP2"):
        tr, _, cpu = fig9[name]
        assert tr.time_s[-1] / cpu > 20.0, name      # about 220 on an idle core


# ---- integration -----------------------------------------------------------------------------
def test_newmark_is_second_order_against_an_rk4_reference():
    cfg = paper_fig9_config(160.0)
    t_star = cfg.parameters().t_star_s
    rows, _ = convergence_study(cfg, 10 * t_star, scaled_steps=(0.0025, 0.00125),
                                schemes=("newmark",), reference_scaled_step=1e-3)
    assert 1.6 < rows[1].order < 2.4
    assert rows[1].max_bit_speed_error_rad_s < 1e-2


def test_stepping_api_matches_simulate_and_follows_the_top_drive():
    cfg = DrillingConfig(section="12.25in", n_elements=6, with_bha=True, top_drive_rpm=160,
                         mud_viscosity_pa_s=0.03)
    one = simulate(cfg, 6.0)
    sim = DrillStringSimulator(cfg)
    two = [sim.advance(2.0), sim.advance(4.0)]
    assert np.array_equal(np.concatenate([p.bit_speed_rad_s for p in two]),
                          one.bit_speed_rad_s)
    sim.advance(10.0, top_drive_rpm=180.0)
    late = sim.advance(20.0, top_drive_rpm=180.0)
    assert np.mean(late.bit_speed_rad_s) == pytest.approx(rpm_to_rad_s(180.0), rel=0.02)
    assert np.mean(late.surface_torque_nm) > 0.0


# ---- report helpers --------------------------------------------------------------------------
def test_report_helpers_return_figures_and_tables():
    speeds = critical_speeds(sections=("36in", "12.25in"), ns=(1, 2))
    assert speeds["36in"][1] == pytest.approx(axial_stability("36in", 2).critical_speed_rpm)
    table = critical_speed_table(speeds, ns=(1, 2))
    assert f"{speeds['12.25in'][1]:.1f}" in table
    assert isinstance(critical_speed_figure(speeds, ns=(1, 2)), Figure)
    assert "15.7675" in crossing_table(axial_stability("36in", 2))


def test_polar_moment_of_the_drill_pipe():
    assert polar_moment_m4(5 * INCH_M, 4.276 * INCH_M) == pytest.approx(1.1879e-5, rel=1e-4)
