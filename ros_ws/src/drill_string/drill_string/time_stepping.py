"""Implicit one-step schemes for M q'' + C q' + K q = f, written as affine maps.

Newmark (average acceleration, beta = 1/4, gamma = 1/2: the scheme of Tengesdal (2021),
Paper IV section 5.2, and thesis section 2.5.3) and the generalised-alpha method of Chung and
Hulbert (thesis section 2.5.4, eqs. (2.109)-(2.114)); Newmark is generalised-alpha with
alpha_m = alpha_f = 0.

For a linear M, C, K and a fixed step h the step from s_k = [q_k, v_k, a_k] to s_{k+1} is
affine in s_k and in the forces at both ends of the step:

    s_{k+1} = Phi s_k + sum_j (G_old[:, j] f_j,k + G_new[:, j] f_j,k+1)

for force patterns b_j (f = sum_j b_j f_j). The drill-string simulator keeps the bit force
unknown until the end-of-step bit velocity and position are known, so it needs exactly this
form: one matrix product for everything but the bit, then a scalar solve for the bit.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class AlphaCoefficients:
    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float

    @classmethod
    def newmark(cls) -> "AlphaCoefficients":
        return cls(0.0, 0.0, 0.25, 0.5)

    @classmethod
    def generalized_alpha(cls, rho_inf: float) -> "AlphaCoefficients":
        """Chung-Hulbert optimal parameters for spectral radius rho_inf at h -> infinity."""
        if not 0.0 <= rho_inf <= 1.0:
            raise ValueError("rho_inf must be in [0, 1]")
        am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        af = rho_inf / (rho_inf + 1.0)
        gamma = 0.5 - am + af
        return cls(am, af, 0.25 * (gamma + 0.5) ** 2, gamma)


@dataclass(frozen=True)
class AffineStep:
    """s_{k+1} = phi @ s_k + g_old @ f_k + g_new @ f_{k+1}; s = [q, v, a]."""
    phi: np.ndarray
    g_old: np.ndarray
    g_new: np.ndarray


def affine_step(mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray,
                patterns: np.ndarray, h: float, c: AlphaCoefficients) -> AffineStep:
    """Build the affine step of one generalised-alpha step of size h.

    ``patterns`` is n x m: column j is the load pattern of force channel j."""
    m_, c_, k_ = (np.asarray(x, dtype=float) for x in (mass, damping, stiffness))
    b = np.asarray(patterns, dtype=float).reshape(m_.shape[0], -1)
    n = m_.shape[0]
    am, af, beta, gamma = c.alpha_m, c.alpha_f, c.beta, c.gamma
    s = (1.0 - am) * m_ + (1.0 - af) * gamma * h * c_ + (1.0 - af) * beta * h * h * k_
    s_inv = np.linalg.inv(s)
    # acceleration at k+1 from (q_k, v_k, a_k) with the forces taken out
    a_q = -s_inv @ k_
    a_v = -s_inv @ (c_ + (1.0 - af) * h * k_)
    a_a = -s_inv @ (am * m_ + (1.0 - af) * h * (1.0 - gamma) * c_
                    + (1.0 - af) * h * h * (0.5 - beta) * k_)
    eye, zero = np.eye(n), np.zeros((n, n))
    acc = np.hstack([a_q, a_v, a_a])
    pos = np.hstack([eye, h * eye, h * h * (0.5 - beta) * eye]) + beta * h * h * acc
    vel = np.hstack([zero, eye, h * (1.0 - gamma) * eye]) + gamma * h * acc
    phi = np.vstack([pos, vel, acc])
    f_acc = s_inv @ b

    def lift(weight: float) -> np.ndarray:
        fa = weight * f_acc
        return np.vstack([beta * h * h * fa, gamma * h * fa, fa])

    return AffineStep(phi, lift(af), lift(1.0 - af))


def block_diagonal(*steps: AffineStep) -> AffineStep:
    """Stack independent systems (e.g. axial and torsional) into one affine step."""
    from scipy.linalg import block_diag
    return AffineStep(block_diag(*[s.phi for s in steps]),
                      block_diag(*[s.g_old for s in steps]),
                      block_diag(*[s.g_new for s in steps]))
