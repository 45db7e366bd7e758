"""The do-mpc peer of NMPC1 (drill_nmpc.peers): its model is the prediction model's, and a few
samples of Case 2's pull-out on the bench loop (drill_nmpc.bench) from the steady state.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.input_layout import U_BLOCK, U_SIZE
from drill_core.rig_root import config_dir
from drill_core.scenario import Initial
from drill_nmpc.bench import TRIP_DISTANCE_M, steady_estimate, supervisor_input
from drill_nmpc.inputs import input_arrays
from drill_nmpc.peers import DoMpcPeer, run_loop
from drill_nmpc.prediction_model import full_state, nmpc_estimation_model

INITIAL = Initial(circulation_m3s=1000.0 / 60000.0, choke_dp_pa=2.0e6, bpp_flow_m3s=0.0)
SAMPLES = 6
BHP_TOLERANCE_PA = 0.5e5      # a quarter of the +-2 bar band, over the first six samples


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


def test_the_do_mpc_model_is_the_prediction_model(config, peer):
    """do-mpc's right-hand side is PredictionModel.rhs, off the steady state too."""
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
        [ps[i] for i in range(m.npar)], 1.0))])
    expected = np.asarray(ours(x, u, par), dtype=float).ravel()
    model = peer.model
    assert model.n_x == m.nd + 1 and model.n_u == U_SIZE
    tvp = np.zeros(model.n_tvp)
    p = np.concatenate([par, [1.0]])
    # the model's rhs as do-mpc evaluates it (private handle: do-mpc has no public one)
    theirs = np.asarray(model._rhs_fun(np.concatenate([x, [0.0]]), u, [], tvp, p, []),
                        dtype=float).ravel()
    assert np.allclose(theirs[:m.nd], expected, rtol=1e-12, atol=1e-12 * np.max(np.abs(expected)))
    assert np.all(np.abs(expected[m.nd_model:]) > 0.0)      # the lags are in it, and not at rest


def test_pull_out_from_the_steady_state(config, peer, pull_out):
    """IPOPT succeeds every sample; the block starts toward the 28 m target within the
    bounds and slew; BHP stays within 0.5 bar of its reference."""
    run, a = pull_out
    assert list(a["fallback"]) == ["none"] * SAMPLES
    assert all(s in ("Solve_Succeeded", "Solved_To_Acceptable_Level") for s in a["status"]), \
        set(a["status"])
    assert np.all(a["iterations"] > 0)
    x, u0 = steady_estimate(nmpc_estimation_model(config, "NMPC1"), INITIAL)
    u0 = supervisor_input(config, u0, INITIAL)
    limits = input_arrays(config.nmpc)
    inputs = np.asarray(a["inputs"])
    first = inputs[0, U_BLOCK] - u0[U_BLOCK]
    assert 0.0 < first <= limits["slew"][U_BLOCK] + 1e-12        # toward the target
    assert inputs[0, U_BLOCK] < TRIP_DISTANCE_M
    assert np.all(inputs >= limits["min"] - 1e-9) and np.all(inputs <= limits["max"] + 1e-9)
    moves = np.diff(np.vstack([u0, inputs]), axis=0)
    assert np.all(np.abs(moves) <= limits["slew"] * (1 + 1e-9))
    assert np.all(moves[:, U_BLOCK] > 0.0)                      # the trip goes on, one way
    err = a["bhp_pa"] - a["bhp_ref_pa"]
    assert np.max(np.abs(err)) <= BHP_TOLERANCE_PA, err
    assert run["bhp_rmse_pa"] <= BHP_TOLERANCE_PA


def test_the_plan_meets_the_slew_and_acceleration_rows(config, peer, pull_out):
    """The rows added through do-mpc's low-level NLP API hold in IPOPT's own plan (the
    last solve's inputs, before the command is clipped)."""
    _, a = pull_out
    plan = np.array([np.asarray(peer.mpc.opt_x_num_unscaled["_u", k, 0]).ravel()
                     for k in range(peer.N)])
    u_prev = np.asarray(a["inputs"])[-2]            # u_{-1} of the last solve
    moves = np.diff(np.vstack([u_prev, plan]), axis=0)
    slew = input_arrays(config.nmpc)["slew"]
    assert np.all(np.abs(moves) <= slew * (1 + 1e-3)), np.max(np.abs(moves) / slew)
    speed_before = np.asarray(a["inputs"])[-2, U_BLOCK] - np.asarray(a["inputs"])[-3, U_BLOCK]
    steps = np.concatenate([[speed_before], moves[:, U_BLOCK]])
    step_limit = config.protection.trip_acceleration_max_mps2 * peer.ts ** 2
    assert np.all(np.abs(np.diff(steps)) <= step_limit * (1 + 1e-3) + 1e-9)
    assert np.max(plan[:, U_BLOCK]) > np.asarray(a["inputs"])[-1, U_BLOCK]   # it plans on out
