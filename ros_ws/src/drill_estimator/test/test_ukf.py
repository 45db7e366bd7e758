"""RigUkf against the truth plant, in-process (no ROS).

The truth is the plant core (drill_plant.plant_model: HB friction, SRK integration with
seeded Wiener increments) with noisy sensors (cfg.plant.measurement_noise). The
drawworks is the real law in miniature: block_command(u_r, measured x_s, integral) fed
through the first-order lag with its rate limit (config actuators.drawworks); the choke
opening, back-pressure pump and mud pump are driven open loop. The filter gets what the
node gets: the drawworks output u_b per plant step (block_input block_position), the
choke flow from the valve law with the opening and the last measured choke dp, bpp flow
and pump pressure, then the measurement at the end of each 0.1 s frame.

Runs: circulating 1000 L/min at ~20 bar choke dp, string at rest (2 min); the paper's
estimation study (pump off, choke 50 % open, run in 28 m, back-pressure pump ramped to
400 L/min at t = 2 min; 2.5 min). NEES uses the states that have a truth (all but theta
and the block-controller integrator z3).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import pytest
from scipy.stats import chi2

from drill_core import hydraulics as hy
from drill_core.block_control import block_command, integral_rate
from drill_core.config import replace
from drill_estimator.model_inputs import frame_inputs
from drill_estimator.ukf import RigUkf
from drill_plant.plant_model import (CLOSED_BOTTOM, PlantLayout, build_frame_function,
                                     held_parameters, steady_state, wiener_increments)

CIRCULATION = 1000.0 / 60000.0      # 1000 L/min
LPM = 1.0 / 60000.0


@pytest.fixture(scope="module")
def plant(cfg, wm):
    return wm, build_frame_function(wm, cfg)


@dataclass
class Run:
    t: list = field(default_factory=list)
    bhp_true: list = field(default_factory=list)
    bhp_est: list = field(default_factory=list)
    theta: list = field(default_factory=list)
    nees: list = field(default_factory=list)
    nis: list = field(default_factory=list)
    dof: list = field(default_factory=list)
    observable: list = field(default_factory=list)
    mean: list = field(default_factory=list)
    var: list = field(default_factory=list)
    ukf: RigUkf | None = None

    def arrays(self):
        return {k: np.asarray(v) for k, v in self.__dict__.items() if isinstance(v, list)}


def simulate(cfg, plant, duration_s, circulation, choke_dp, schedule, seed, nan_frames=(),
             model_wm=None, em=None):
    """Truth plant + drawworks + sensors, filtered by RigUkf; returns the logged run.

    ``schedule(t)`` -> (u_r m, choke opening or None, bpp m^3/s, pump Pa or None, circulating).
    ``model_wm``: the filter's well model for its choke-flow input (default: the plant's);
    ``em``: the filter's estimation model (default: the configuration's).
    """
    wm, frame = plant
    model_wm = model_wm or wm
    lay = PlantLayout(wm.n)
    rng = np.random.default_rng(seed)
    steps, sub, h = cfg.plant.steps_per_frame, cfg.plant.substeps, cfg.plant.step_s
    noise = cfg.plant.measurement_noise
    sigma = np.array([noise.block_position_m, noise.choke_dp_pa, noise.bhp_pa, noise.string_flow_m3s])
    p0 = wm.well.choke_downstream_pressure_pa
    ss = steady_state(wm, circulation, choke_dp, 0.0)
    x = ss.state.copy()
    opening, pump = ss.inputs[1], ss.inputs[3]
    dw_cfg, act = cfg.actuators.drawworks, cfg.actuators
    block, integral = ss.inputs[0], 0.0
    keep = np.exp(-h / dw_cfg.time_constant_s)

    def measure(state, circulating):
        y = np.array([state[lay.position], state[lay.pressure(1)] - p0, state[lay.pressure(wm.n)],
                      state[lay.string_flow]]) + sigma * rng.normal(size=4)
        if not circulating:
            y[3] = np.nan
        return y

    circulating = circulation > 0.0
    y = measure(x, circulating)
    ukf = RigUkf(cfg, em=em)
    em = ukf.em
    ukf.initialise(ukf.initial_state(y, circulating))
    # states with a truth: z1, z2, p_1, (q_i, p_i) for i = 2..n, q_d, p_I
    est_idx, tru_idx = [0, 1, em.pressure(1)], [lay.position, lay.velocity, lay.pressure(1)]
    for i in range(2, wm.n + 1):
        est_idx += [em.flow(i), em.pressure(i)]
        tru_idx += [lay.flow(i), lay.pressure(i)]
    est_idx += [em.string_flow, em.string_pressure]
    tru_idx += [lay.string_flow, lay.string_pressure]
    last_dp = y[1]
    run = Run(ukf=ukf)
    for k in range(int(round(duration_s / cfg.plant.sensor_period_s))):
        t = k * cfg.plant.sensor_period_s
        u_r, new_opening, bpp, new_pump, circulating = schedule(t)
        opening = opening if new_opening is None else new_opening
        pump = pump if new_pump is None else new_pump
        # drawworks: block-position controller on the measured position + lag with rate limit
        command = block_command(u_r, y[0], integral, wm.geometry.static_stretch_m, act.block_kp,
                                act.block_ki_per_s)
        integral += integral_rate(u_r, y[0]) * steps * h
        u = np.empty((4, steps))
        for j in range(steps):
            u[0, j] = block
            change = (command - block) * (1.0 - keep)
            limit = dw_cfg.rate_limit_per_s * h
            block += min(max(change, -limit), limit)
        u[1], u[2], u[3] = opening, bpp, pump
        dw = wiener_increments(rng, lay, steps * sub, h / sub)
        x = np.asarray(frame(x, u, dw, held_parameters(CLOSED_BOTTOM, steps)))[:, -1]
        y = measure(x, circulating)
        if k in nan_frames:
            y[2] = np.nan
        # the estimator's view of the frame
        ukf.predict_frame(np.vstack([u[0], frame_inputs(model_wm, 0.0, u[1], u[2], u[3],
                                                        last_dp)[1:]]))
        result = ukf.update(y, circulating)
        if np.isfinite(y[1]):
            last_dp = y[1]
        mean, cov = ukf.mean, ukf.covariance
        err = mean[est_idx] - x[tru_idx]
        run.t.append(t + cfg.plant.sensor_period_s)
        run.bhp_true.append(x[lay.pressure(wm.n)])
        run.bhp_est.append(ukf.bhp_pa)
        run.theta.append(ukf.theta)
        run.nees.append(float(err @ np.linalg.solve(cov[np.ix_(est_idx, est_idx)], err)))
        run.nis.append(result.nis)
        run.dof.append(result.nis_dof)
        run.observable.append(result.string_flow_observable)
        run.mean.append(mean)
        run.var.append(ukf.covariance_diagonal)
    return run


def _rest(t):
    return 0.0, None, 0.0, None, True


def test_circulating_at_rest_bhp_theta_nees_nis(cfg, plant):
    run = simulate(cfg, plant, 120.0, CIRCULATION, 2.0e6, _rest, seed=11)
    a = run.arrays()
    settled = a["t"] > 20.0
    rmse = float(np.sqrt(np.mean((a["bhp_est"][settled] - a["bhp_true"][settled]) ** 2)))
    # NEES: 11 states with a truth; NIS: 4 channels; two-sided 95 % chi-square bounds
    n_err = 2 * plant[0].n + 3
    nees = a["nees"][settled]
    nees_inside = float(np.mean((nees > chi2.ppf(0.025, n_err)) & (nees < chi2.ppf(0.975, n_err))))
    nees_below = float(np.mean(nees < chi2.ppf(0.975, n_err)))
    nis, dof = a["nis"][settled], a["dof"][settled]
    nis_inside = float(np.mean((nis > chi2.ppf(0.025, dof)) & (nis < chi2.ppf(0.975, dof))))
    theta = a["theta"]
    last = a["t"] > a["t"][-1] - 30.0
    theta_change = np.max(np.abs(theta[last] - theta[-1]), axis=0) / theta[-1]
    print(f"\ncirculating at rest: BHP RMSE {rmse / 1e5:.3f} bar, NEES inside {nees_inside:.2f} "
          f"(below upper {nees_below:.2f}, mean {nees.mean():.1f} of {n_err}), NIS inside "
          f"{nis_inside:.2f} (mean {nis.mean():.2f} of 4), theta {np.round(theta[-1] / 1e6, 2)} e6, "
          f"relative change over last 30 s {np.round(theta_change, 3)}, counters {run.ukf.counters}")
    noise = cfg.plant.measurement_noise.bhp_pa
    assert rmse < 0.4 * noise
    assert np.all(theta_change < 0.1)
    if cfg.estimator.annular_friction_law == "scaled_rheology":
        # one common correction (theta_correlation): the paths' factors stay together
        assert np.ptp(theta[-1]) < 0.02 and np.all(np.abs(theta[-1] - 1.0) < 0.1)
    assert nees_inside > 0.6 and nees_below > 0.9
    assert nis_inside > 0.85
    assert all(a["observable"])
    assert run.ukf.rejected == 0 and run.ukf.resets == 0


def _run_in(t):
    """Paper's estimation study: pump off, choke 50 %, run in 28 m, bpp to 400 L/min at 2 min."""
    u_r = 0.0 if t < 10.0 else max(-28.0, -0.4 * (t - 10.0))
    bpp = 0.0 if t < 120.0 else min(400.0 * LPM, 400.0 * LPM * (t - 120.0) / 20.0)
    return u_r, 0.5, bpp, 0.0, False


def test_circulation_off_run_in_stays_bounded(cfg, plant):
    run = simulate(cfg, plant, 150.0, 0.0, 0.0, _run_in, seed=5)
    a = run.arrays()
    ukf = run.ukf
    em = ukf.em
    rmse = float(np.sqrt(np.mean((a["bhp_est"] - a["bhp_true"]) ** 2)))
    print(f"\ncirculation off, run in 28 m: BHP RMSE {rmse / 1e5:.2f} bar, max |error| "
          f"{np.max(np.abs(a['bhp_est'] - a['bhp_true'])) / 1e5:.2f} bar, final theta "
          f"{np.round(a['theta'][-1] / 1e6, 1)} e6, counters {ukf.counters}")
    assert np.all(np.isfinite(a["mean"])) and np.all(np.isfinite(a["var"]))
    assert not any(a["observable"]) and set(a["dof"]) == {3}
    # every standard deviation stays under its cap (max_std_factor x initial std)
    cap = cfg.estimator.max_std_factor * np.sqrt(np.diag(ukf.tuning.initial)) * ukf.scale
    assert np.all(np.sqrt(a["var"]) <= cap * (1 + 1e-6) + 1e-12)
    # the unobservable string states stay physical: q_d within +-500 L/min of zero,
    # p_I within 50 bar of the string's hydrostatic column
    assert np.max(np.abs(a["mean"][:, em.string_flow])) < 500.0 * LPM
    g = em.wm.geometry
    column = cfg.well.mud.density_kgm3 * cfg.well.gravity_mps2 * (g.bit_depth_m - a["mean"][:, 0])
    assert np.max(np.abs(a["mean"][:, em.string_pressure] - column)) < 50e5
    assert rmse < 5e5          # bounded; the quadratic law cannot hold the gelled mud (paper: bias)
    assert abs(a["mean"][-1, 0] - (-28.0)) < 0.3


def test_a_non_finite_channel_is_left_out_and_the_others_fused(cfg, plant):
    run = simulate(cfg, plant, 2.0, CIRCULATION, 2.0e6, _rest, seed=3, nan_frames=(5, 6, 12))
    a = run.arrays()
    assert run.ukf.rejected_channels == 3 and run.ukf.rejected == 0
    assert np.all(np.isfinite(a["mean"])) and np.all(np.isfinite(a["var"]))
    assert np.isfinite(a["nis"][5]) and np.isfinite(a["nis"][4])
    ukf = run.ukf
    ss = steady_state(ukf.em.wm, CIRCULATION, 2.0e6, 0.0)
    inputs = _held([ss.inputs[0], ss.choke_flow_m3s, 0.0, ss.inputs[3]], cfg)
    # one bad channel: the three good ones still correct the prediction
    ukf.predict_frame(inputs)
    before = ukf.mean.copy()
    result = ukf.update([0.0, np.inf, ukf.bhp_pa + 5.0e5, CIRCULATION], True)
    assert result.accepted and result.dropped == ("choke_dp_pa",) and result.nis_dof == 3
    assert result.measurement_names == ("block_position_m", "bhp_pa", "string_flow_m3s")
    assert ukf.bhp_pa > before[ukf.em.pressure(ukf.em.n)]          # pulled toward the 5 bar step
    assert ukf.rejected_channels == 4
    # no finite channel: rejected, the prediction untouched
    ukf.predict_frame(inputs)
    before, var_before = ukf.mean.copy(), ukf.covariance_diagonal.copy()
    result = ukf.update([np.nan, np.inf, np.nan, np.nan], True)
    assert not result.accepted and ukf.rejected == 1
    np.testing.assert_array_equal(ukf.mean, before)
    np.testing.assert_array_equal(ukf.covariance_diagonal, var_before)
    # a missing string flow is fine while not circulating, and a dict works too
    result = ukf.update({"block_position_m": 0.0, "choke_dp_pa": 2e6, "bhp_pa": ukf.bhp_pa}, False)
    assert result.accepted and result.nis_dof == 3 and not result.string_flow_observable


def _held(u, cfg):
    """Inputs [4 x steps_per_frame] holding ``u`` over one sensor frame."""
    return np.repeat(np.asarray(u, dtype=float)[:, None], cfg.plant.steps_per_frame, axis=1)


def _started(cfg, **changes):
    if changes:
        cfg = replace(cfg, estimator=replace(cfg.estimator, **changes))
    ukf = RigUkf(cfg)
    wm = ukf.em.wm
    ss = steady_state(wm, CIRCULATION, 2.0e6, 0.0)
    y = [0.0, 2.0e6, ss.state[PlantLayout(wm.n).pressure(wm.n)], CIRCULATION]
    ukf.initialise(ukf.initial_state(y, True))
    return ukf, ss, y


def test_covariance_guards_repair_and_reset(cfg):
    ukf, ss, y = _started(cfg)
    u = [ss.inputs[0], ss.choke_flow_m3s, 0.0, ss.inputs[3]]
    ukf.predict_frame(_held(u, cfg))
    # an indefinite covariance is repaired (jitter / eigenvalue clipping), not a crash
    P = ukf._ukf.P.copy()
    P[3, 3] = -abs(P[3, 3])
    ukf._ukf.P = P
    ukf.predict_frame(_held(u, cfg))
    assert ukf.repairs >= 1 and np.all(np.isfinite(ukf.mean))
    assert np.all(np.linalg.eigvalsh(0.5 * (ukf._ukf.P + ukf._ukf.P.T)) > -1e-9)
    # a non-finite covariance is reset to the initial one and counted
    ukf._ukf.P[2, 5] = np.nan
    result = ukf.update(y, True)
    assert ukf.resets == 1 and result.accepted
    assert np.all(np.isfinite(ukf.covariance)) and np.all(np.isfinite(ukf.mean))


def test_nis_alarm_inflates_covariance(cfg):
    ukf, ss, y = _started(cfg, nis_window=10)
    u = [ss.inputs[0], ss.choke_flow_m3s, 0.0, ss.inputs[3]]
    rng = np.random.default_rng(0)
    results = []
    for _ in range(30):      # a BHP sensor 5x noisier than the filter assumes
        ukf.predict_frame(_held(u, cfg))
        results.append(ukf.update(np.array(y) + [0.0, 0.0, 5.0e5 * rng.normal(), 0.0], True))
    assert ukf.inflations >= 1
    assert any(r.nis_alarm for r in results)
    assert np.all(np.isfinite(ukf.mean))


def test_bottom_influx_state(cfg):
    ukf, ss, y = _started(cfg, estimate_bottom_influx=True)
    assert ukf.em.with_disturbance and ukf.n_x == 18     # with the density offset and bulk modulus
    assert ukf.state_names[-1] == "bottom_influx_m3s"
    u = [ss.inputs[0], ss.choke_flow_m3s, 0.0, ss.inputs[3]]
    for _ in range(5):
        ukf.predict_frame(_held(u, cfg))
        ukf.update(y, True)
    assert np.isfinite(ukf.bottom_influx_m3s) and abs(ukf.bottom_influx_m3s) < 1e-3
    assert ukf.covariance_diagonal.shape == (18,)


def test_reference_block_input_runs(cfg):
    """block_input "reference": u[0] is the drawworks reference u_r (model controller, no lag)."""
    ukf, ss, y = _started(cfg, block_input="reference")
    assert ukf.block_input == "reference"
    u = [0.0, ss.choke_flow_m3s, 0.0, ss.inputs[3]]
    for _ in range(5):
        ukf.predict_frame(_held(u, cfg))
        result = ukf.update(y, True)
    assert result.accepted and np.all(np.isfinite(ukf.mean))
    assert abs(ukf.mean[0]) < 0.01 and abs(ukf.bhp_pa - y[2]) < 1e5


def test_the_density_offset_learns_a_mud_heavier_than_its_report(cfg, plant):
    """The plant's mud 0.8 % (14.4 kg/m^3) heavier than well.yaml, circulating at rest: the
    filter's density offset starts part of the way (the first BHP reading's departure from
    the report's profile, split with the friction factor by their priors), ends within
    5 kg/m^3 of the truth in 2 minutes, and its BHP estimate holds the truth within the
    sensor's noise."""
    from drill_core.mismatch import Mismatch, truth_config
    truth = truth_config(cfg, Mismatch(density_factor=1.008))
    wm = hy.rig_well_model(truth)
    run = simulate(cfg, (wm, build_frame_function(wm, truth)), 120.0, CIRCULATION, 2.0e6,
                   _rest, seed=11, model_wm=plant[0])
    a = run.arrays()
    offset = a["mean"][:, run.ukf.em.density_offset]
    assert abs(offset[-1] - 14.4) < 5.0 and 2.0 < offset[0] < 14.4
    settled = a["t"] > 20.0
    rmse = float(np.sqrt(np.mean((a["bhp_est"][settled] - a["bhp_true"][settled]) ** 2)))
    assert rmse < cfg.plant.measurement_noise.bhp_pa


def _choke_opened_on_a_softer_mud(cfg, em=None):
    """The plant's mud 15 % softer (bulk modulus) than the report, circulating at rest; at
    10 s the choke opens to 1.5 times its opening (BHP falls about 7.5 bar and the annulus
    gives up more mud than the report's compressibility says). The filter carries the
    bottom influx (and with it the bulk modulus factor, unless ``em`` says otherwise)."""
    from drill_core.mismatch import Mismatch, truth_config
    cfg = replace(cfg, estimator=replace(cfg.estimator, estimate_bottom_influx=True))
    truth = truth_config(cfg, Mismatch(bulk_modulus_factor=0.85))
    wm = hy.rig_well_model(truth)
    model_wm = hy.rig_well_model(cfg)
    opening = steady_state(wm, CIRCULATION, 2.0e6, 0.0).inputs[1]

    def schedule(t):
        return 0.0, opening * (1.0 if t < 10.0 else 1.5), 0.0, None, True
    return simulate(cfg, (wm, build_frame_function(wm, truth)), 60.0, CIRCULATION, 2.0e6,
                    schedule, seed=11, model_wm=model_wm, em=em)


def test_the_bulk_modulus_factor_reads_a_softer_mud_not_an_influx(cfg):
    """With the factor the influx estimate stays under 8 L/min and the factor ends within
    0.05 of the truth's 0.85; the same filter without it reads the released mud as an
    influx of more than 12 L/min (there is none)."""
    run = _choke_opened_on_a_softer_mud(cfg)
    em = run.ukf.em
    a = run.arrays()
    assert em.with_bulk_modulus
    assert np.max(a["mean"][:, em.disturbance]) < 8.0 * LPM
    assert abs(a["mean"][-1, em.bulk_modulus] - 0.85) < 0.05
    without = dataclasses.replace(em, with_bulk_modulus=False)
    b = _choke_opened_on_a_softer_mud(cfg, without).arrays()
    assert np.max(b["mean"][:, without.disturbance]) > 12.0 * LPM


def test_a_string_held_in_the_slips_settles_on_its_measured_position(cfg):
    """The filter starts 5 cm off the string (one noisy reading) as the slips hold it: the
    held time update keeps each sigma point's string at rest where it is, so the position
    readings pull the estimate onto the gripped string and the velocity stays zero (a block
    input shared by the points pulled every point to the mean and kept the offset)."""
    ukf, ss, y = _started(cfg)
    em = ukf.em
    u = [ss.inputs[0], ss.choke_flow_m3s, 0.0, ss.inputs[3]]
    ukf.initialise(ukf.initial_state([0.05, *y[1:]], True))
    assert ukf.mean[em.position] == pytest.approx(0.05)
    for _ in range(100):                                  # 10 s in the slips at 0 m
        ukf.predict_frame(_held(u, cfg), held=True)
        ukf.update(y, True)
    position_std_m = math.sqrt(ukf.covariance_diagonal[em.position])
    assert abs(ukf.mean[em.position]) < min(0.002, 3.0 * position_std_m)   # shared: 5.2 mm, 7 std
    assert abs(ukf.mean[em.velocity]) < 1e-3
    assert abs(ukf.bhp_pa - y[2]) < 0.5e5
