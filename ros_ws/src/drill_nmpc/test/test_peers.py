"""The NMPC1 peers (drill_nmpc.peers: do-mpc; drill_nmpc.peer_gekko: GEKKO): each one's model
is the prediction model's, and a few samples of Case 2's pull-out on the bench loop
(drill_nmpc.bench) from the steady state (GEKKO's: about 4 s per sample, its apm run).
"""
from __future__ import annotations

import os

import casadi as ca
import numpy as np
import pytest
from gekko import GEKKO

from drill_core.config import load_rig
from drill_core.input_layout import U_BLOCK, U_SIZE
from drill_core.rig_root import config_dir
from drill_core.scenario import Initial
from drill_nmpc.bench import TRIP_DISTANCE_M, steady_estimate, supervisor_input
from drill_nmpc.inputs import input_arrays
from drill_nmpc.peer_gekko import CIRCULATING, GekkoPeer, gekko_namespace, values
from drill_nmpc.peers import DoMpcPeer, run_loop
from drill_nmpc.prediction_model import full_state, nmpc_estimation_model

INITIAL = Initial(circulation_m3s=1000.0 / 60000.0, choke_dp_pa=2.0e6, bpp_flow_m3s=0.0)
SAMPLES = 6
BHP_TOLERANCE_PA = 0.5e5      # a quarter of the +-2 bar band, over the first six samples
GEKKO_SAMPLES = 4
GEKKO_BHP_MAX_ERROR_PA = 0.5e5    # measured 0.34 bar over the first four samples
GEKKO_BHP_RMSE_PA = 0.35e5        # measured 0.26 bar
GEKKO_RHS_RTOL = 1e-4         # GEKKO's cubic splines through the CasADi tables' values: 1.3e-5
BOUND_RTOL = 1e-5             # IPOPT relaxes bounds by 1e-8 of the (span-scaled) variables


@pytest.fixture(scope="module")
def config():
    return load_rig(config_dir())


@pytest.fixture(scope="module")
def peer(config):
    return DoMpcPeer(config)


@pytest.fixture(scope="module")
def pull_out(config, peer):
    """Case 2's pull-out target from the first sample, SAMPLES samples."""
    run = run_loop(config, peer, SAMPLES, out_at=0.0, in_at=1.0e9)
    return run, run["log"].arrays()


@pytest.fixture(scope="module")
def gekko_peer(config):
    peer = GekkoPeer(config)
    yield peer
    peer.close()


@pytest.fixture(scope="module")
def gekko_pull_out(config, gekko_peer):
    """Case 2's pull-out target from the first sample, GEKKO_SAMPLES samples."""
    run = run_loop(config, gekko_peer, GEKKO_SAMPLES, out_at=0.0, in_at=1.0e9)
    return run, run["log"].arrays()


def off_steady_point(config, peer, friction_pump_on=None):
    """A state, input and parameters off Case 2's steady state, and PredictionModel.rhs
    there (on CasADi symbols, mud pump on)."""
    em, m = peer.em, peer.model_pred
    x_est, u = steady_estimate(em, INITIAL)
    u = supervisor_input(config, u, INITIAL)
    x0 = m.initial_state(full_state(em, x_est), u)
    par = x_est[m.nd_model:]
    rng = np.random.default_rng(1)
    x = x0 * (1.0 + 0.01 * rng.standard_normal(x0.size))
    u = u * (1.0 + 0.05 * rng.standard_normal(U_SIZE)) + np.array([0.0, 0.0, 1.0e-3, 0.0])
    xs, us, ps = ca.SX.sym("x", m.nd), ca.SX.sym("u", U_SIZE), ca.SX.sym("p", m.npar)
    ours = ca.Function("rhs", [xs, us, ps], [ca.vertcat(*m.rhs(
        [xs[i] for i in range(m.nd)], [us[i] for i in range(U_SIZE)],
        [ps[i] for i in range(m.npar)], 1.0, friction_pump_on))])
    expected = np.asarray(ours(x, u, par), dtype=float).ravel()
    assert np.all(np.abs(expected[m.nd_model:]) > 0.0)      # the lags are in it, and not at rest
    return x, u, par, expected


def check_pull_out(config, run, a, samples: int, max_error_pa: float, rmse_pa: float):
    """Every sample solved; the block starts toward the 28 m target within the bounds,
    slew and acceleration; BHP within ``max_error_pa`` of its reference."""
    assert list(a["fallback"]) == ["none"] * samples
    _, u0 = steady_estimate(nmpc_estimation_model(config, "NMPC1"), INITIAL)
    u0 = supervisor_input(config, u0, INITIAL)
    limits = input_arrays(config.nmpc)
    inputs = np.asarray(a["inputs"])
    assert np.all(np.isfinite(inputs))
    first = inputs[0, U_BLOCK] - u0[U_BLOCK]
    assert 0.0 < first <= limits["slew"][U_BLOCK] + 1e-12        # toward the target
    assert inputs[-1, U_BLOCK] < TRIP_DISTANCE_M
    assert np.all(inputs >= limits["min"] - 1e-9) and np.all(inputs <= limits["max"] + 1e-9)
    moves = np.diff(np.vstack([u0, inputs]), axis=0)
    assert np.all(np.abs(moves) <= limits["slew"] * (1 + 1e-9))
    assert np.all(moves[:, U_BLOCK] > 0.0)                      # the trip goes on, one way
    err = a["bhp_pa"] - a["bhp_ref_pa"]
    assert np.max(np.abs(err)) <= max_error_pa, err
    assert run["bhp_rmse_pa"] <= rmse_pa


def check_plan(config, plan, inputs, ts: float, rtol: float):
    """The last solve's own plan (before the command is clipped) keeps the slew and the
    acceleration limits from u_{-1} and the last period's move, and plans on out."""
    moves = np.diff(np.vstack([inputs[-2], plan]), axis=0)     # u_{-1} of the last solve
    slew = input_arrays(config.nmpc)["slew"]
    assert np.all(np.abs(moves) <= slew * (1 + rtol)), np.max(np.abs(moves) / slew)
    steps = np.concatenate([[inputs[-2, U_BLOCK] - inputs[-3, U_BLOCK]], moves[:, U_BLOCK]])
    step_limit = config.protection.trip_acceleration_max_mps2 * ts ** 2
    assert np.all(np.abs(np.diff(steps)) <= step_limit * (1 + rtol) + 1e-9)
    assert np.max(plan[:, U_BLOCK]) > inputs[-1, U_BLOCK]       # it plans on out


def test_the_do_mpc_model_is_the_prediction_model(config, peer):
    """do-mpc's right-hand side is PredictionModel.rhs, off the steady state too."""
    m = peer.model_pred
    x, u, par, expected = off_steady_point(config, peer)
    model = peer.model
    assert model.n_x == m.nd + 1 and model.n_u == U_SIZE
    tvp = np.zeros(model.n_tvp)
    p = np.concatenate([par, [1.0]])
    # the model's rhs as do-mpc evaluates it (private handle: do-mpc has no public one)
    theirs = np.asarray(model._rhs_fun(np.concatenate([x, [0.0]]), u, [], tvp, p, []),
                        dtype=float).ravel()
    assert np.allclose(theirs[:m.nd], expected, rtol=1e-12, atol=1e-12 * np.max(np.abs(expected)))


def test_pull_out_from_the_steady_state(config, peer, pull_out):
    """IPOPT succeeds every sample; the block starts toward the 28 m target within the
    bounds and slew; BHP stays within 0.5 bar of its reference."""
    run, a = pull_out
    assert all(s in ("Solve_Succeeded", "Solved_To_Acceptable_Level") for s in a["status"]), \
        set(a["status"])
    assert np.all(a["iterations"] > 0)
    check_pull_out(config, run, a, SAMPLES, BHP_TOLERANCE_PA, BHP_TOLERANCE_PA)


def test_the_plan_meets_the_slew_and_acceleration_rows(config, peer, pull_out):
    """The rows added through do-mpc's low-level NLP API hold in IPOPT's own plan."""
    _, a = pull_out
    plan = np.array([np.asarray(peer.mpc.opt_x_num_unscaled["_u", k, 0]).ravel()
                     for k in range(peer.N)])
    check_plan(config, plan, np.asarray(a["inputs"]), peer.ts, 1e-3)


def test_the_gekko_model_is_the_prediction_model(config, gekko_peer):
    """PredictionModel.rhs on GEKKO's expressions (the peer's namespace, evaluated by
    GEKKO's apm) equals it on CasADi's, off the steady state too."""
    m = gekko_peer.model_pred
    x, u, par, expected = off_steady_point(config, gekko_peer, CIRCULATING)
    g = GEKKO(remote=False)
    try:
        rhs = m.rhs([g.Param(v) for v in x], [g.Param(v) for v in u], [g.Param(v) for v in par],
                    g.Param(1.0), CIRCULATING, xp=gekko_namespace(g))
        rates = [g.Var() for _ in rhs]
        for rate, expression in zip(rates, rhs):
            g.Equation(rate == expression)
        g.options.IMODE = 1
        g.options.RTOL = 1e-12
        g.solve(disp=False)
        theirs = np.array([values(rate)[0] for rate in rates])
    finally:
        g.cleanup()
    assert np.allclose(theirs, expected, rtol=GEKKO_RHS_RTOL, atol=1e-12), \
        (theirs - expected) / expected


def test_gekko_pull_out_from_the_steady_state(config, gekko_peer, gekko_pull_out):
    """GEKKO solves every sample; the block starts toward the 28 m target within the
    bounds, slew and acceleration; BHP stays near its reference."""
    run, a = gekko_pull_out
    assert list(a["status"]) == ["success"] * GEKKO_SAMPLES
    check_pull_out(config, run, a, GEKKO_SAMPLES, GEKKO_BHP_MAX_ERROR_PA, GEKKO_BHP_RMSE_PA)


def test_gekkos_plan_meets_the_slew_and_acceleration_limits(config, gekko_peer, gekko_pull_out):
    """GEKKO has the slew and acceleration limits as bounds of its moves: its plan keeps them."""
    _, a = gekko_pull_out
    span = input_arrays(config.nmpc)["span"]
    sample_points = slice(gekko_peer.substeps, None, gekko_peer.substeps)
    plan = np.array([values(v)[sample_points] * k
                     for v, k in zip(gekko_peer.scaled_inputs, span)]).T
    assert plan.shape == (gekko_peer.N, U_SIZE)
    check_plan(config, plan, np.asarray(a["inputs"]), gekko_peer.ts, BOUND_RTOL)


def test_close_removes_gekkos_directory(config):
    """GEKKO's files go to a temporary directory that close() removes."""
    peer = GekkoPeer(config)
    path = peer.m.path
    assert os.path.isdir(path)
    peer.close()
    assert not os.path.exists(path)
