"""NMPC supervisor in-process (no ROS): integrator check, closed-loop trip on the model plant,
the three configurations, infeasible starts and the fallback policy, setpoint validation.

The plant is the shared estimation model (exact string friction, RK4, 20 steps per sample)
plus the drawworks lag, see drill_nmpc.bench; the supervisor gets its exact state.
"""
from __future__ import annotations

import dataclasses
import math

import casadi as ca
import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.integrators import rk4_step
from drill_core.rig_root import config_dir
from drill_core.scenario import ActiveSetpoints, Initial
from drill_nmpc.bench import (ModelPlant, closed_loop, steady_estimate, supervisor_input,
                              trip_setpoints)
from drill_nmpc.inputs import choke_command, input_arrays
from drill_nmpc.prediction_model import (ActuatorLags, PredictionModel, StringFrictionTable,
                                         nmpc_estimation_model, outputs)
from drill_nmpc.soft_constraints import SLACK_NAMES
from drill_nmpc.supervisor import Supervisor
from drill_nmpc.transcription import GAP_TOLERANCE
from drill_nmpc.setpoint_validation import Envelope, validate_setpoints

CONFIG_DIR = config_dir()
INITIAL = Initial(circulation_m3s=1000.0 / 60000.0, choke_dp_pa=2.0e6, bpp_flow_m3s=0.0)


@pytest.fixture(scope="module")
def config():
    return load_rig(CONFIG_DIR)


@pytest.fixture(scope="module")
def em(config):
    return nmpc_estimation_model(config)


def _steady(config, em):
    """A steady state and the supervisor's input vector there (choke entry per mode)."""
    x, u = steady_estimate(em, INITIAL)
    return x, supervisor_input(config, u, INITIAL)


def _raises_bhp(config) -> float:
    """The sign of a change of the choke input u[1] that raises BHP: a higher dp set-point
    (choke_control pressure) or less choke flow (flow)."""
    return 1.0 if config.nmpc.choke_control == "pressure" else -1.0


def _bounds(config):
    inputs = input_arrays(config.nmpc)
    return inputs["min"], inputs["max"], inputs["slew"]


def _check_inputs(config, inputs, u0):
    lo, hi, slew = _bounds(config)
    u = np.vstack([u0, np.asarray(inputs)])
    assert np.all(np.isfinite(u))
    assert np.all(u[1:] >= lo - 1e-9) and np.all(u[1:] <= hi + 1e-9)
    assert np.all(np.abs(np.diff(u, axis=0)) <= slew * (1 + 1e-9) + 1e-12)


# ----------------------------------------------------------------------------- model
def test_string_friction_table_matches_the_shared_model(em):
    table = StringFrictionTable(em.wm)
    assert table.applies()
    assert table.max_error_pa < 1.0e3          # < 0.01 bar against ~30-150 bar


def test_rk4_is_stable_and_accurate_where_forward_euler_is_not(config, em):
    """The hoisting/hydraulic modes (|lambda| ~ 3.2 rad/s, lightly damped): forward Euler
    with the paper's M = 10 (h = 0.1 s) amplifies them; RK4 with the configured M is close
    to a fine reference over the 15 s horizon."""
    x, u = steady_estimate(em, INITIAL)
    model = PredictionModel(em, ActuatorLags.from_config(config), StringFrictionTable(em.wm))
    x0, par = model.initial_state(x, u), x[model.nd_model:]

    def simulate(substeps, integrator):
        F = model.function(1.0, substeps, integrator)
        xs, out = x0.copy(), []
        for j in range(15):
            uj = u.copy()
            uj[0] = 0.5 * (j + 1)                         # pull-out ramp of the block reference
            uj[3] = u[3] + 1.0e5 * min(j, 3)
            xs = np.asarray(F(xs, uj, par, 1.0)).ravel()
            out.append(xs.copy())
        return np.array(out)

    reference = simulate(100, "rk4")
    bhp = em.pressure(em.n)
    ours = simulate(config.nmpc.substeps, config.nmpc.integrator)
    assert config.nmpc.integrator == "rk4"
    assert np.max(np.abs(ours[:, bhp] - reference[:, bhp])) < 0.5e5       # < 0.5 bar
    euler = simulate(10, "euler")
    assert not np.all(np.isfinite(euler)) or \
        np.max(np.abs(euler[:, bhp] - reference[:, bhp])) > 5.0e5          # > 5 bar off



def test_the_sample_maps_jacobian_is_the_chain_of_its_steps(config, em):
    """F's explicit Jacobian (the chain rule over its RK4 steps) against CasADi's automatic
    differentiation of the same steps unrolled into one expression, in every argument, at
    a pull-out's state and inputs."""
    x, u = steady_estimate(em, INITIAL)
    model = PredictionModel(em, ActuatorLags.from_config(config), StringFrictionTable(em.wm))
    x0, par = model.initial_state(x, u), x[model.nd_model:]
    u = u.copy()
    u[0] += 0.4                                            # the block reference moving up
    steps = 5
    F = model.function(1.0, steps, "rk4")
    symbols = [ca.SX.sym("x", model.nd), ca.SX.sym("u", 4), ca.SX.sym("par", model.npar),
               ca.SX.sym("pump_on")]
    rhs = lambda s: ca.vertcat(*model.rhs([s[i] for i in range(model.nd)], *symbols[1:]))
    unrolled = symbols[0]
    for _ in range(steps):
        unrolled = rk4_step(rhs, unrolled, 1.0 / steps)
    reference = ca.Function("reference", symbols, [unrolled] + [ca.jacobian(unrolled, s)
                                                                for s in symbols[:2]])
    args = [x0, u, par, 1.0]
    value, *expected = reference(*args)
    assert np.allclose(np.asarray(F(*args)), np.asarray(value), rtol=1e-12, atol=0.0)
    jac_x, jac_u, jac_par, jac_pump_on = F.jacobian()(*args, value)
    for ours, theirs in zip((jac_x, jac_u), expected):
        theirs = np.asarray(theirs)
        assert np.allclose(np.asarray(ours), theirs, rtol=1e-10, atol=1e-12 * np.max(np.abs(theirs)))
    assert jac_par.nnz() == 0 and jac_pump_on.nnz() == 0       # the NLP's parameters: held

# ----------------------------------------------------------------------------- closed loop
def test_trip_out_and_back_nmpc0(config):
    """Pull a stand out (28 m) and run it back in: BHP in its band, velocity limit, bounds, slew."""
    log, sup = closed_loop(config, "NMPC0", 380, out_at=2.0, in_at=190.0)
    a = log.arrays()
    x0, u0 = _steady(config, nmpc_estimation_model(config))
    _check_inputs(config, a["inputs"], u0)
    assert np.all(a["fallback"] == "none"), set(a["fallback"])
    assert np.max(np.abs(a["velocity_mps"])) <= config.nmpc.velocity_limit_mps + 0.03
    err = a["bhp_pa"] - a["bhp_ref_pa"]
    band = config.nmpc.bhp_band_pa
    assert np.mean(np.abs(err) <= band + 0.2e5) >= 0.9           # in band most of the time
    assert np.max(np.abs(err)) <= band + 1.0e5                   # never far outside
    assert np.max(a["block_position_m"]) > 27.5                  # the stand is out
    assert abs(a["block_position_m"][-1]) < 0.5                  # and back in
    assert np.all(a["choke_dp_pa"] > 0.0)


@pytest.mark.parametrize("configuration", ["NMPC1", "NMPC2"])
def test_offset_free_configurations_run(config, configuration):
    """NMPC1 (integrated error, friction mismatch) and NMPC2 (estimated bottom influx)."""
    log, sup = closed_loop(config, configuration, 12, out_at=100.0,
                           friction_factor=1.3 if configuration == "NMPC1" else 1.0,
                           influx_m3s=2.0e-4 if configuration == "NMPC2" else 0.0)
    a = log.arrays()
    _, u0 = _steady(config, nmpc_estimation_model(config))
    _check_inputs(config, a["inputs"], u0)
    assert sup.configuration == configuration
    assert np.all(a["fallback"] != "hold")
    if configuration == "NMPC1":
        assert sup.problem.ne == 2 and np.any(sup.integral != 0.0)
    else:
        assert sup.em.with_disturbance
    err = a["bhp_pa"] - a["bhp_ref_pa"]
    # a 30 % friction error is a step of several bar at t = 0; the choke set-point moves
    # at most choke_dp_setpoint.slew_pa per sample and the pumps hold the circulation
    settle = 6 if config.nmpc.choke_control == "pressure" else 4
    assert np.max(np.abs(err[settle:])) <= config.nmpc.bhp_band_pa + 1.0e5


def test_nmpc2_uses_the_influx_estimate(config):
    """The disturbance estimate enters the prediction: with an influx the plan differs."""
    em2 = nmpc_estimation_model(config, "NMPC2")
    x, u = _steady(config, em2)
    sp = trip_setpoints(0.0, 100.0, 200.0, float(outputs(em2, x)[2]))
    a = Supervisor(config, em2, configuration="NMPC2", jit=False).step(x, sp, u, disturbance=0.0)
    b = Supervisor(config, em2, configuration="NMPC2", jit=False).step(x, sp, u, disturbance=5e-4)
    # the influx raises BHP: the plan lowers it (a lower dp set-point, or more choke flow)
    s = _raises_bhp(config)
    span = input_arrays(config.nmpc)["span"][1]
    assert s * (b.u[1] - a.u[1]) < 0.0
    assert np.all(s * (b.planned_inputs[:, 1] - a.planned_inputs[:, 1]) <= 1e-6 * span)
    assert np.max(s * (a.planned_inputs[:, 1] - b.planned_inputs[:, 1])) > 0.01 * span


# ----------------------------------------------------------------------------- infeasible starts
@pytest.fixture(scope="module")
def supervisor(config, em):
    return Supervisor(config, em, configuration="NMPC0", jit=False)


def test_bhp_far_outside_its_band_is_handled(config, em, supervisor):
    x, u = _steady(config, em)
    bhp = float(outputs(em, x)[2])
    sp = trip_setpoints(0.0, 100.0, 200.0, bhp + 30.0e5)      # 30 bar above: unreachable now
    supervisor.reset()
    r = supervisor.step(x, sp, u)
    _check_inputs(config, [r.u], u)
    assert r.fallback in ("none", "relaxed", "hold")
    if r.fallback != "hold":
        assert r.slacks["bhp_band"] > 1.0e5                    # the band is violated softly
        assert _raises_bhp(config) * (r.u[1] - u[1]) > 0.0       # the choke raises BHP


def test_velocity_above_the_limit_is_handled(config, em, supervisor):
    x, u = _steady(config, em)
    x = x.copy()
    x[1] = 1.0                                                 # estimate 1 m/s > 0.5 m/s
    sp = trip_setpoints(0.0, 100.0, 200.0, float(outputs(em, x)[2]))
    supervisor.reset()
    r = supervisor.step(x, sp, u)
    _check_inputs(config, [r.u], u)
    assert all(math.isfinite(v) or r.fallback == "hold" for v in r.slacks.values())


def test_invalid_estimate_holds_the_last_input(config, em, supervisor):
    x, u = _steady(config, em)
    x = x.copy()
    x[em.pressure(2)] = math.nan
    count = supervisor.fallback_count
    r = supervisor.step(x, trip_setpoints(0.0, 1.0, 2.0, 7.0e7), u)
    assert r.fallback == "hold" and not r.success and r.reasons == ("invalid_estimate",)
    assert np.array_equal(r.u, np.clip(u, *_bounds(config)[:2]))
    assert supervisor.fallback_count == count + 1


def test_fallback_policy_relaxed_then_hold(config, em, supervisor, monkeypatch):
    """A failed solve is retried with the relaxed constraint set, then the input is held."""
    x, u = _steady(config, em)
    sp = trip_setpoints(0.0, 0.0, 100.0, float(outputs(em, x)[2]))
    pb = supervisor.problem
    real = pb.solve
    calls = []

    def failing_first(p, z0, lbz, ubz, lbg, ubg, lam_z0=None, lam_g0=None):
        calls.append(np.isinf(lbg).sum())
        sol = real(p, z0, lbz, ubz, lbg, ubg, lam_z0, lam_g0)
        if len(calls) == 1:
            sol["stats"] = {"success": False, "return_status": "Infeasible_Problem_Detected",
                            "iter_count": 3}
        return sol

    supervisor.reset()
    monkeypatch.setattr(pb, "solve", failing_first)
    r = supervisor.step(x, sp, u)
    assert r.fallback == "relaxed" and r.success
    assert r.reasons == ("cold attempt: Infeasible_Problem_Detected",)
    assert calls[1] > calls[0]                     # the retry dropped constraint rows
    _check_inputs(config, [r.u], u)

    def always_nan(*args, **kwargs):
        sol = real(*args, **kwargs)
        sol["z"] = sol["z"] * math.nan
        return sol

    monkeypatch.setattr(pb, "solve", always_nan)
    r = supervisor.step(x, sp, u)
    assert r.fallback == "hold" and not r.success
    # the relaxed solve before left no warm start: a cold start, then the relaxed set
    assert [reason.split(":")[0] for reason in r.reasons] == ["cold attempt", "relaxed attempt"]
    assert np.all(np.isfinite(r.u))


def test_a_hold_puts_the_choke_on_its_pressure_loop_at_the_dp_for_the_reference_at_rest(
        config, em, supervisor, monkeypatch):
    """Holding a choke flow reference with the pump off lets the pressure run away against
    the back-pressure pump: a run of holds holds, on the choke's pressure loop, the steady dp
    that puts BHP at the reference with the string at rest and no circulation - the BHP
    less the mud column (1800 kg/m^3 over 3607.8 m: 637.07 bar) - fixed when the run
    began; a solve ends it."""
    x, u = _steady(config, em)
    pump_off = supervisor.problem_for(False)
    real = pump_off.solve

    def always_nan(*args, **kwargs):
        sol = real(*args, **kwargs)
        sol["z"] = sol["z"] * math.nan
        return sol

    supervisor.reset()
    off = dataclasses.replace(trip_setpoints(0.0, 0.0, 0.0, 6.85e7), mud_pump_on=False,
                              choke_dp_band_upper_pa=6.63e7)
    monkeypatch.setattr(pump_off, "solve", always_nan)
    r = supervisor.step(x, off, u)
    assert r.fallback == "hold"
    assert r.hold_choke_dp_pa == pytest.approx(6.85e7 - 637.07e5, abs=0.01e5)
    choke = choke_command(config.nmpc, r, 0.01)
    assert choke.pressure_control and choke.dp_ref_pa == r.hold_choke_dp_pa
    assert choke.dp_ref_rate_pa_s == 0.0 and choke.flow_m3s == r.u[1]   # its feed-forward
    again = supervisor.step(x, dataclasses.replace(off, bhp_ref_pa=6.8e7), u)
    assert again.hold_choke_dp_pa == r.hold_choke_dp_pa                # fixed over the run
    monkeypatch.setattr(pump_off, "solve", real)
    solved = supervisor.step(x, trip_setpoints(0.0, 0.0, 100.0, float(outputs(em, x)[2])), u)
    assert solved.fallback != "hold" and math.isnan(solved.hold_choke_dp_pa)
    assert not choke_command(config.nmpc, solved, 0.01).pressure_control


def test_an_unusable_warm_start_is_rolled_out_again_before_any_fallback(config, em, supervisor,
                                                                         monkeypatch):
    """The shifted previous solution's iterate rejected: its inputs are rolled out through
    the prediction model (no dynamics gaps) and solved with every constraint; no fallback."""
    x, u = _steady(config, em)
    sp = trip_setpoints(0.0, 0.0, 100.0, float(outputs(em, x)[2]))
    supervisor.reset()
    r = supervisor.step(x, sp, u)                       # a plan to shift
    pb = supervisor.problem
    real = pb.solve
    starts = []

    def reject_the_shifted_one(p, z0, lbz, ubz, lbg, ubg, lam_z0=None, lam_g0=None):
        g = np.array(pb.nlp_functions(z0, p)[1]).ravel()
        model_rows = [st.gap.start + i for st in pb.stages if st.gap is not None
                      for i in range(pb.nd)]           # the prediction model's states
        starts.append((float(np.max(np.abs(g[model_rows]))), lam_z0 is None))
        sol = real(p, z0, lbz, ubz, lbg, ubg, lam_z0, lam_g0)
        if len(starts) == 1:
            sol["stats"] = dict(sol["stats"], return_status="Infeasible_Problem_Detected")
        return sol

    monkeypatch.setattr(pb, "solve", reject_the_shifted_one)
    fallbacks, rollouts = supervisor.fallback_count, supervisor.rollouts
    r = supervisor.step(x, sp, r.u)
    assert len(starts) == 2 and starts[0][0] > 1e-3
    assert starts[1] == (pytest.approx(0.0, abs=1e-9), True)
    assert r.fallback == "none" and "warm start rolled out" in r.reasons
    assert supervisor.fallback_count == fallbacks and supervisor.rollouts == rollouts + 1


def test_the_integral_rollout_is_the_nlps_own(config, em):
    """NMPC1's integral along a rolled-out trajectory leaves no gap in the NLP; held at
    e_0 it would (the BHP 3 bar off its set-point)."""
    sup = Supervisor(config, em, configuration="NMPC1", jit=False)
    pb = sup.problem
    x, u = _steady(config, em)
    x0 = sup.model.initial_state(x, u)
    par = x[sup.model.nd_model:]
    U = np.tile(u, (pb.N, 1))
    X = pb.simulate(x0, par, U)
    y_sp = np.array([0.0, 2.0e6, float(outputs(em, x)[2]) - 3.0e5])
    e0 = np.array([0.1, -0.2])
    p = pb.parameters(x0, par, u, e0, np.tile(y_sp, pb.N), y_sp, u, True, 0.0, 1.0e4)
    gaps = []
    for E in (pb.integral_rollout(X, par, e0, y_sp, 1.0e4), np.tile(e0, (pb.N + 1, 1))):
        _, g = pb.nlp_functions(pb.pack(x0, u, X, U, E, {}), p)
        gaps.append(pb.dynamics_gap(np.array(g).ravel(), pb._lbg0, pb._ubg0))
    assert gaps[0] < 1e-9 and gaps[1] > 0.1


def _gaps_on_the_full_step(pb, calls: list):
    """``pb.nlp_functions`` with the first evaluation (the full RTI step) ten tolerances off
    the model in its first stage's gaps; each evaluated point is appended to ``calls``."""
    real_nlp = pb.nlp_functions

    def evaluate(z, p):
        f, g = real_nlp(z, p)
        calls.append(z)
        g = np.array(g).ravel().copy()
        if len(calls) == 1:
            g[pb.stages[0].gap] += 10.0 * GAP_TOLERANCE
        return f, g
    return evaluate


def test_a_step_too_long_for_the_linearisation_is_shortened(config, em, supervisor, monkeypatch):
    """A full real-time-iteration step with dynamics gaps over the tolerance is halved (the
    multipliers with it) until they are within it."""
    x, u = _steady(config, em)
    sp = trip_setpoints(0.0, 0.0, 100.0, float(outputs(em, x)[2]))
    pb = supervisor.problem
    calls = []
    real_rti = pb._rti_step
    seen = {}

    def spy(p, z0, *args):
        seen["z0"] = z0
        seen["out"] = real_rti(p, z0, *args)
        return seen["out"]

    supervisor.reset()
    monkeypatch.setattr(pb, "nlp_functions", _gaps_on_the_full_step(pb, calls))
    monkeypatch.setattr(pb, "_rti_step", spy)
    r = supervisor.step(x, sp, u)
    out = seen["out"]
    assert out["stats"]["step_fraction"] == 0.5 and len(calls) == 2
    assert np.allclose(out["z"] - seen["z0"], 0.5 * (calls[0] - seen["z0"]))
    assert r.fallback == "none" and "step shortened to 0.5" in r.reasons


def test_a_plan_pinned_since_the_last_solve_is_in_the_shifted_warm_start(config, em, supervisor,
                                                                          monkeypatch):
    """The rig floor's pump ramp-down appears in the plan between two solves (a connection
    begins, the block pinned at the stand's end): the shifted previous solution carries the
    ramp's pinned inputs, so a step shortened for the linearisation still meets them and
    the shifted start is used (off the plan, half a step misses the pins by half the ramp:
    the attempt was rejected)."""
    x, u = _steady(config, em)
    slew = _bounds(config)[2]
    sp = trip_setpoints(0.0, 0.0, 100.0, float(outputs(em, x)[2]))
    N = supervisor.problem.Nc
    steady = np.full((N, 4), np.nan)
    steady[:, 0], steady[:, 3] = u[0], u[3]
    supervisor.reset()
    r = supervisor.step(x, sp, u, fixed_inputs=steady)
    ramp = steady.copy()
    ramp[:, 3] = u[3] - 3.5 * slew[3] * np.arange(1, N + 1)
    pb = supervisor.problem
    real_rti = pb._rti_step
    calls, starts = [], []

    def spy(p, z0, lbz, ubz, *args):
        starts.append(np.max(np.abs(z0 - lbz)[lbz == ubz]))
        return real_rti(p, z0, lbz, ubz, *args)

    monkeypatch.setattr(pb, "nlp_functions", _gaps_on_the_full_step(pb, calls))
    monkeypatch.setattr(pb, "_rti_step", spy)
    r = supervisor.step(x, sp, r.u, fixed_inputs=ramp)
    assert starts[0] < 1e-9                             # the shifted start on the pins
    assert r.fallback == "none" and r.reasons == ("step shortened to 0.5",)
    assert r.u[3] == ramp[0, 3]


def test_result_fields(config, em, supervisor):
    x, u = _steady(config, em)
    supervisor.reset()
    r = supervisor.step(x, trip_setpoints(0.0, 0.0, 100.0, float(outputs(em, x)[2])), u)
    N = config.nmpc.prediction_steps
    assert set(r.slacks) == set(SLACK_NAMES)
    assert r.predicted_time_s.shape == (N + 1,)
    assert r.planned_inputs.shape == (N, 4)
    for key in ("block_position_m", "choke_dp_pa", "bhp_pa", "string_velocity_mps"):
        assert r.predicted[key].shape == (N + 1,) and np.all(np.isfinite(r.predicted[key]))
    assert r.solve_time_s > 0.0 and math.isfinite(r.cost)


# ----------------------------------------------------------------------------- validation
def _sp(**changes):
    base = ActiveSetpoints(bhp_ref_pa=6.85e7, bhp_band_pa=2.0e5, choke_dp_ref_pa=2.0e6,
                           choke_dp_band_pa=5.0e5, block_position_target_m=28.0,
                           trip_speed_limit_mps=0.5, controller_enabled=True, mud_pump_on=True)
    return dataclasses.replace(base, **changes)


@pytest.mark.parametrize("changes, word", [
    ({"bhp_ref_pa": -1.0e5}, "bhp_ref_pa"),
    ({"bhp_ref_pa": math.nan}, "not a finite"),
    ({"bhp_ref_pa": 6.0e7}, "static mud column"),
    ({"bhp_ref_pa": 6.66e7}, "pore pressure"),
    ({"bhp_ref_pa": 7.04e7}, "fracture pressure"),
    ({"bhp_band_pa": 0.0}, "bhp_band_pa"),
    ({"choke_dp_band_pa": -1.0}, "choke_dp_band_pa"),
    ({"choke_dp_ref_pa": -5.0e5}, "choke_dp_ref_pa"),
    ({"block_position_target_m": 40.0}, "drawworks range"),
    ({"trip_speed_limit_mps": 0.8}, "trip_speed_limit_mps"),
    ({"trip_speed_limit_mps": 0.0}, "trip_speed_limit_mps"),
])
def test_validator_refuses_with_a_reason(config, em, changes, word):
    ok, reason = validate_setpoints(_sp(**changes), Envelope.from_config(config, em.wm.geometry))
    assert not ok and word in reason


def test_validator_accepts_a_sound_request(config, em):
    env = Envelope.from_config(config, em.wm.geometry)
    assert validate_setpoints(_sp(), env) == (True, "")
    f, margin = config.well.formation, config.protection.pressure_margin_pa
    assert env.pore_pressure_pa == f.pore_pressure_pa + margin
    assert env.fracture_pressure_pa == f.fracture_pressure_pa - margin
    assert 6.3e7 < env.hydrostatic_pa < 6.45e7                 # ~637 bar at the bit


def test_model_plant_matches_its_state_layout(config, em):
    x, u = steady_estimate(em, INITIAL)
    plant = ModelPlant(config, em, x, u)
    y0 = plant.state(em)
    assert np.allclose(y0[:em.theta(em.n) + 1], x[:em.theta(em.n) + 1])
    plant.advance(supervisor_input(config, u, INITIAL))
    y1 = plant.state(em)
    assert np.allclose(y1[em.pressure(em.n)], x[em.pressure(em.n)], atol=0.05e5)   # steady


def test_trip_corridor_is_monotone_and_does_not_ratchet(config, em):
    """The block reference stays between the furthest point the string reached on its way
    to the target and the target (+- 0.5 m): no backing up, and a string that overshoots
    does not drag the corridor along."""
    sup = Supervisor(config, em, configuration="NMPC0", jit=False)
    x = np.zeros(em.size)
    held = np.zeros(4)
    assert sup.block_range(x, held, 8.0) == pytest.approx((-0.5, 8.5))
    x[0] = 5.0                                       # on the way: no going back below 4.5 m
    assert sup.block_range(x, np.array([5.0, 0, 0, 0]), 8.0) == pytest.approx((4.5, 8.5))
    x[0] = 3.0                                       # pushed back: the corridor stays
    assert sup.block_range(x, np.array([5.0, 0, 0, 0]), 8.0)[0] == pytest.approx(4.5)
    x[0] = 9.5                                       # overshoot past the target
    lo, hi = sup.block_range(x, np.array([9.5, 0, 0, 0]), 8.0)
    assert lo == pytest.approx(7.5) and hi < 9.5     # only back toward the target (or braking)
    x[0] = 9.6
    assert sup.block_range(x, np.array([hi, 0, 0, 0]), 8.0)[1] <= hi + 1e-12
    assert sup.block_range(x, held, 0.0) == pytest.approx((-0.5, 10.1))   # a new trip: from 9.6 m


def test_only_a_multi_stand_trip_pays_for_running_past_the_stands_end(config, em):
    """A multi-stand trip's OCP bounds the string to the allowance past its target in the
    direction of travel (the floor takes a stand as arrived only at rest near its end);
    no other OCP carries the rows, and no band applies while no move is under way."""
    single = Supervisor(config, em, configuration="NMPC0", jit=False)
    trip = Supervisor(config, em, configuration="NMPC0", jit=False, floor_trip=True)
    rows = lambda sup: {name for st in sup.problem.stages for name in st.rows}
    assert "stand_end" not in rows(single) and "stand_end" in rows(trip)
    allowance = config.nmpc.stand_end_allowance_m
    x = np.zeros(em.size)
    assert trip.stand_end_band() == (-math.inf, math.inf)
    trip.block_range(x, np.zeros(4), 28.0)                      # pulling out: up to 28 m
    assert trip.stand_end_band() == pytest.approx((-math.inf, 28.0 + allowance))
    x[em.position] = 28.4                                       # past it: the band stays
    trip.block_range(x, np.array([28.0, 0, 0, 0]), 28.0)
    assert trip.stand_end_band() == pytest.approx((-math.inf, 28.0 + allowance))
    trip.block_range(x, np.array([28.0, 0, 0, 0]), 0.0)         # running in: down to 0 m
    assert trip.stand_end_band() == pytest.approx((-allowance, math.inf))
    trip.block_range(x, np.array([28.0, 0, 0, 0]), 28.4)        # held where it is
    assert trip.stand_end_band() == (-math.inf, math.inf)


def test_block_integral_comes_from_the_drawworks_command(config, em):
    """The UKF (fed the block position) cannot observe the block controller's integral; the
    prediction takes it from the drawworks' last command: c = block_command(u_r, z1, z3)."""
    model = PredictionModel(em, ActuatorLags.from_config(config), None)
    x, u = steady_estimate(em, INITIAL)
    x = x.copy()
    x[0], x[2] = 3.0, 123.0                                   # a drifted integral estimate
    command = model.block_command(3.4, 3.0, 0.7)
    x0 = model.initial_state(x, u, {"block_command_m": float(command), "block_reference_m": 3.4})
    assert x0[2] == pytest.approx(0.7)
    assert model.initial_state(x, u, {})[2] == 123.0          # no frame: the estimate stands


def test_pressure_loop_model_is_a_first_order_lag_of_the_set_point(config, em):
    """With the choke on its pressure loop the prediction's choke dp follows its set-point
    with the configured time constant (the flow out is what makes it so)."""
    tau = config.nmpc.choke_dp_setpoint.time_constant_s
    model = PredictionModel(em, ActuatorLags.from_config(config), StringFrictionTable(em.wm), tau)
    x, u = steady_estimate(em, INITIAL)
    x0, par = model.initial_state(x, u), x[model.nd_model:]
    u_dp = u.copy()
    u_dp[1] = INITIAL.choke_dp_pa + 1.0e5                      # +1 bar set-point step
    F = model.function(0.1, 1, "rk4")
    xs, dp = x0.copy(), []
    for _ in range(50):
        xs = np.asarray(F(xs, u_dp, par, 1.0)).ravel()
        dp.append(xs[em.pressure(1)] - INITIAL.choke_dp_pa)
    assert dp[int(round(tau / 0.1)) - 1] == pytest.approx(1.0e5 * (1.0 - math.exp(-1.0)), rel=0.05)
    assert dp[-1] == pytest.approx(1.0e5, rel=0.02)
    flow = float(model.choke_flow(x0, u_dp))
    assert flow < INITIAL.circulation_m3s                     # less out: the pressure rises


def test_the_real_time_iteration_is_one_full_gauss_newton_sqp_step(config, em):
    """solver rti (our QP of the linearisation, full step) against CasADi's sqpmethod
    limited to one iteration without line search: the same step, to the QP's accuracy."""
    x, u = _steady(config, em)
    sp = trip_setpoints(0.0, 0.0, 200.0, float(outputs(em, x)[2]))    # pull out from now
    rti = Supervisor(config, em, configuration="NMPC0", solver="rti").step(x, sp, u)
    sqp = Supervisor(config, em, configuration="NMPC0", solver="sqpmethod",
                     solver_options={"max_iter": 1, "max_iter_ls": 0}).step(x, sp, u)
    assert rti.fallback == sqp.fallback == "none"
    span = input_arrays(config.nmpc)["span"]
    assert np.max(np.abs(rti.planned_inputs - sqp.planned_inputs) / span) < 1.0e-4
    assert rti.planned_inputs[-1, 0] > u[0] + 1.0            # the plan pulls out


def test_the_real_time_iteration_needs_the_gauss_newton_hessian(config, em):
    with pytest.raises(ValueError, match="Gauss-Newton"):
        Supervisor(config, em, solver="rti", hessian="exact")


def test_nmpc1_integral_leaks_while_the_output_is_inside_its_band(config, em):
    """BHP at its reference (inside the band): a wound-up integral decays by exp(-t_s/T)
    per sample with a leak time T, and is kept without one."""
    x, u = _steady(config, em)
    sp = trip_setpoints(0.0, 0.0, 100.0, float(outputs(em, x)[2]))
    kept = []
    for leak_s in (10.0, 0.0):
        cfg = dataclasses.replace(config, nmpc=dataclasses.replace(
            config.nmpc, integral_leak_time_s=leak_s))
        sup = Supervisor(cfg, em, configuration="NMPC1", jit=False)
        sup.integral = np.array([0.0, 1.0])
        sup.step(x, sp, u)
        kept.append(float(sup.integral[-1]))
    assert kept[0] == pytest.approx(math.exp(-config.nmpc.sample_time_s / 10.0), rel=1e-9)
    assert kept[1] == pytest.approx(1.0)


def test_pinned_inputs_are_planned_as_given_past_the_slew(config, em, supervisor):
    """A rig floor's pump ramp-down pinned on the stand-pipe pressure, 3.5 bar a sample (3.5
    slews), and the block pinned where it is: the plan and the command take them as given;
    the choke and the back-pressure pump stay the NMPC's."""
    x, u = _steady(config, em)
    slew = _bounds(config)[2]
    N = supervisor.problem.Nc
    fixed = np.full((N, 4), np.nan)
    fixed[:, 3] = u[3] - 3.5 * slew[3] * np.arange(1, N + 1)
    fixed[:, 0] = u[0]
    supervisor.reset()
    r = supervisor.step(x, trip_setpoints(0.0, 100.0, 200.0, float(outputs(em, x)[2])), u,
                        fixed_inputs=fixed)
    assert r.fallback == "none"
    np.testing.assert_allclose(r.planned_inputs[:N, 3], fixed[:, 3], rtol=0, atol=1e-3)
    np.testing.assert_allclose(r.planned_inputs[:N, 0], u[0], rtol=0, atol=1e-9)
    assert r.u[3] == fixed[0, 3] and abs(r.u[3] - u[3]) > 3.0 * slew[3]
    assert np.all(np.abs(np.diff(r.planned_inputs[:N, 1])) <= slew[1] * (1 + 1e-6))
