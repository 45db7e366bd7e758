"""Convergence of the one-step integrators against problems with known solutions.

Strong order: geometric Brownian motion dX = mu X dt + sigma X dW (diagonal,
multiplicative noise) has the exact solution X_T = X_0 exp((mu - sigma^2/2) T + sigma W_T),
evaluated on the same seeded Brownian paths the schemes see. Deterministic order: the
logistic equation y' = y (1 - y), y(t) = 1 / (1 + 9 e^-t) for y(0) = 0.1.
"""
from __future__ import annotations

import numpy as np
import pytest

from drill_core import integrators as it

MU, SIGMA, X0, T = 1.0, 0.8, 1.0, 1.0
PATHS = 4000
FINEST = 2 ** 10
LEVELS = (4, 8, 16, 32, 64, 128)     # steps over [0, T]


def _order(step_sizes, errors):
    return np.polyfit(np.log(step_sizes), np.log(errors), 1)[0]


# ----------------------------------------------------------------------- coefficients
def test_deterministic_order3_conditions():
    """Butcher conditions for order 3 of the drift part (A0, alpha): the printed thesis
    coefficients, c = A0 row sums = [0, 2/3, 2/3]."""
    a = np.zeros((3, 3))
    for i, row in enumerate(it.A0):
        a[i, :len(row)] = row
    alpha = np.array(it.ALPHA)
    c = a.sum(axis=1)
    assert np.allclose(c, [0.0, 2.0 / 3.0, 2.0 / 3.0], atol=1e-15)
    assert alpha.sum() == pytest.approx(1.0, abs=1e-15)
    assert alpha @ c == pytest.approx(1.0 / 2.0, abs=1e-15)
    assert alpha @ c ** 2 == pytest.approx(1.0 / 3.0, abs=1e-15)
    assert alpha @ a @ c == pytest.approx(1.0 / 6.0, abs=1e-15)
    # order 4 conditions fail (3 stages cannot reach it): alpha . c^3 != 1/4
    assert abs(alpha @ c ** 3 - 0.25) > 1e-3


def test_stochastic_order1_conditions():
    """Conditions for strong order 1 (Ito, diagonal noise) of the diffusion weights:
    sum gamma1 = 1 (the dW term), sum gamma2 = 0, and with the B1 stage shifts
    b_i = sum_j B1_ij: gamma2 . b = 1 (Milstein term g g' I_11) and gamma1 . b = 0."""
    b1 = np.array([sum(row) for row in it.B1])
    g1, g2 = np.array(it.GAMMA1), np.array(it.GAMMA2)
    assert g1.sum() == pytest.approx(1.0, abs=1e-15)
    assert g2.sum() == pytest.approx(0.0, abs=1e-15)
    assert g2 @ b1 == pytest.approx(1.0, abs=1e-15)
    assert g1 @ b1 == pytest.approx(0.0, abs=1e-15)


# ------------------------------------------------------------------- deterministic
def test_deterministic_orders():
    f = lambda y: y * (1.0 - y)  # noqa: E731
    exact = 1.0 / (1.0 + 9.0 * np.exp(-4.0))
    schemes = {
        "srk": (lambda y, h: it.srk_step(f, lambda s: 0.0 * s, y, h, 0.0), 3.0),
        "rk4": (lambda y, h: it.rk4_step(f, y, h), 4.0),
        "euler": (lambda y, h: it.euler_step(f, y, h), 1.0),
    }
    for name, (step, order) in schemes.items():
        errors, sizes = [], []
        for n in (32, 64, 128, 256):
            h = 4.0 / n
            y = np.array([0.1])
            for _ in range(n):
                y = step(y, h)
            errors.append(abs(y[0] - exact))
            sizes.append(h)
        # asymptotic range (errors 1e-6..1e-10, far above rounding): +-0.3
        assert _order(sizes, errors) == pytest.approx(order, abs=0.3), name


# ---------------------------------------------------------------------- stochastic
@pytest.fixture(scope="module")
def brownian():
    rng = np.random.default_rng(20240521)
    return rng.standard_normal((FINEST, PATHS)) * np.sqrt(T / FINEST)


def _strong_errors(step, increments_fine, exact):
    errors, sizes = [], []
    for n in LEVELS:
        h = T / n
        dw = increments_fine.reshape(n, FINEST // n, PATHS).sum(axis=1)
        x = np.full(PATHS, X0)
        for k in range(n):
            x = step(x, h, dw[k])
        errors.append(np.mean(np.abs(x - exact)))
        sizes.append(h)
    return np.array(sizes), np.array(errors)


def test_strong_order_gbm(brownian):
    exact = X0 * np.exp((MU - 0.5 * SIGMA ** 2) * T + SIGMA * brownian.sum(axis=0))

    def srk(x, h, dw):
        return it.srk_step(lambda s: MU * s, lambda s: SIGMA * s, x, h, dw)

    def euler_maruyama(x, h, dw):
        return x + MU * x * h + SIGMA * x * dw

    h, e_srk = _strong_errors(srk, brownian, exact)
    _, e_em = _strong_errors(euler_maruyama, brownian, exact)
    p_srk, p_em = _order(h, e_srk), _order(h, e_em)
    # with 4000 paths the Monte-Carlo error of each mean |error| is ~2 %, i.e. +-0.03 on
    # the fitted slope over 5 octaves; the brief's bands are much wider than that
    assert 0.8 < p_srk < 1.3            # measured 0.99
    assert 0.35 < p_em < 0.65           # measured 0.49: the test tells the schemes apart
    assert e_srk[-1] < 0.1 * e_em[-1]


def test_strong_order_additive_noise(brownian):
    """The plant's case: additive noise (Ornstein-Uhlenbeck). Reference: the same scheme on
    the finest grid of the same paths; the self-convergence order must stay >= 1."""
    theta, sigma = 2.0, 0.5

    def srk(x, h, dw):
        return it.srk_step(lambda s: -theta * s, lambda s: sigma + 0.0 * s, x, h, dw)

    x = np.full(PATHS, X0)
    for k in range(FINEST):
        x = srk(x, T / FINEST, brownian[k])
    h, errors = _strong_errors(srk, brownian, x)
    assert _order(h[:-1], errors[:-1]) > 0.9     # measured 1.0
