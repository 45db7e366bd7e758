"""One-step integrators written with plain arithmetic, so they run on numpy arrays
and CasADi symbols alike.

``srk_step`` is Rossler's explicit stochastic Runge-Kutta scheme for Ito SDEs with
diagonal noise (thesis section 2.5.2; Rossler 2010, SRI-type with the coefficients
of the thesis): deterministic order 3, strong order 1. With additive noise it is a
third-order Runge-Kutta for the drift plus g dW.
"""
from __future__ import annotations

from dataclasses import dataclass

# Butcher-type coefficients as printed in the thesis (3 stages), checked against the
# deterministic order-3 conditions: sum(alpha) = 1, alpha.c = 1/2, alpha.c^2 = 1/3,
# alpha.A.c = 1/6 (see test_integrators.py).
A0 = ((), (2.0 / 3.0,), (-1.0 / 3.0, 1.0))
B0 = ((), (1.0,), (0.0, 0.0))
A1 = ((), (1.0,), (1.0, 0.0))
B1 = ((), (1.0,), (-1.0, 0.0))
ALPHA = (0.25, 0.5, 0.25)
GAMMA1 = (0.5, 0.25, 0.25)
GAMMA2 = (0.0, 0.5, -0.5)


def srk_step(drift, diffusion, x, h: float, dw):
    """One step of Rossler's SRK for dx = drift(x) dt + diag(diffusion(x)) dW.

    ``dw`` holds the Wiener increments over the step (variance h), elementwise with x.
    """
    sqrt_h = h ** 0.5
    f, g = [], []
    h0, h1 = [], []
    for i in range(3):
        s0, s1 = x, x
        for j in range(i):
            s0 = s0 + A0[i][j] * h * f[j] + B0[i][j] * g[j] * dw
            s1 = s1 + A1[i][j] * h * f[j] + B1[i][j] * g[j] * sqrt_h
        h0.append(s0)
        h1.append(s1)
        f.append(drift(s0))
        g.append(diffusion(s1))
    x_next = x
    milstein = (dw * dw - h) / (2.0 * sqrt_h)
    for i in range(3):
        x_next = x_next + ALPHA[i] * h * f[i] + (GAMMA1[i] * dw + GAMMA2[i] * milstein) * g[i]
    return x_next


def rk4_step(drift, x, h: float):
    """Classical fourth-order Runge-Kutta step for dx/dt = drift(x)."""
    k1 = drift(x)
    k2 = drift(x + 0.5 * h * k1)
    k3 = drift(x + 0.5 * h * k2)
    k4 = drift(x + h * k3)
    return x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def euler_step(drift, x, h: float):
    """Forward Euler step (the paper's NMPC discretisation)."""
    return x + h * drift(x)


@dataclass(frozen=True)
class WithSensitivity:
    """A state and its sensitivity d x / d p (forward), stepped by ``rk4_step`` or
    ``euler_step`` like a state: they take only sums and products with numbers. The drift
    given them returns the drift's value and its sensitivity, d f/dx S + d f/dp."""
    value: object
    sensitivity: object

    def __add__(self, other: "WithSensitivity") -> "WithSensitivity":
        return WithSensitivity(self.value + other.value, self.sensitivity + other.sensitivity)

    def __rmul__(self, factor: float) -> "WithSensitivity":
        return WithSensitivity(factor * self.value, factor * self.sensitivity)
