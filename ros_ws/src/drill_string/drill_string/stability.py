"""Decoupled axial stability of the n-block string with the blade delay (Walton-Marshall).

Tengesdal (2021), Paper IV section 3.1: with the torsion steady (constant delay tau_n =
2 pi / (n_b omega_0)) and the wear flats engaged, the axial perturbations obey the linear
delay equation (43); in modal coordinates (27)-(31) its characteristic quasi-polynomial is

    P(s, tau) = A(s) - B(s) exp(-s tau),   p_j(s) = s^2 + d_hat s + omega_j^2,
    B(s) = n_b alpha sum_j V_nj^2 prod_{i != j} p_i(s),  A(s) = prod_j p_j(s) + B(s)   (33), (36)

Imaginary-axis crossings s = j w happen only where F(w) = |A(jw)|^2 - |B(jw)|^2 = 0 (37);
the delays of a crossing follow from the phase of B/A (39)-(40) and its direction (roots
entering or leaving the right half plane as tau grows) from the sign of F'(w). Counting the
crossings in delay order from the stable tau = 0 gives the stable delay windows; the first
destabilising crossing is the delay margin, and tau = 2 pi / (n_b omega_0) turns delays into
top-drive speeds (Omega_0 = omega_0 / t*).

F has degree 4n, and its coefficients lose all precision long before n = 40 (the paper's
limit, section 4.2). Here F is never expanded: with q(w) = 1 + 2 Re G(jw), G = B / prod p_j =
n_b alpha sum_j V_nj^2 / p_j, F = |prod p_j|^2 q, so the crossing frequencies are the roots of
q, found by bracketing on a grid refined geometrically around every omega_j (near each
omega_j sits a root within about d_hat^2 of it) and polished with Brent's method.
``characteristic_polynomials`` gives the expanded A, B, F for small n as a cross-check.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.polynomial import polynomial as npoly
from scipy.linalg import eigh
from scipy.optimize import brentq

from .lumped_model import scaled_axial_matrices
from .parameters import LumpedParameters, WellSection, derive, rad_s_to_rpm, rpm_to_rad_s


@dataclass(frozen=True)
class Switch:
    """One imaginary-axis crossing: at delay ``delay`` a root pair crosses at +-j w."""
    delay: float
    frequency: float
    direction: int          # +1 destabilising (F' > 0), -1 stabilising
    branch: int             # r in (40)


@dataclass(frozen=True)
class StabilityResult:
    """Decoupled axial stability of one configuration; delays and frequencies are in the
    scaled time of Paper IV (t* = L / c_t), speeds in rad/s and rpm."""
    section: str
    n: int
    with_bha: bool
    mud_viscosity_pa_s: float
    t_star_s: float
    n_blades: int
    d_hat: float
    nb_alpha: float
    eigenfrequencies: np.ndarray          # omega_j, descending
    modal_weights: np.ndarray             # V_nj^2, same order
    crossing_frequencies: np.ndarray      # omega_k*, descending
    directions: np.ndarray                # sign F'(omega_k*)
    phases: np.ndarray                    # theta_k in [0, 2 pi), (39)
    switches: tuple[Switch, ...] = field(repr=False)
    stable_delay_intervals: tuple[tuple[float, float], ...] = ()
    delay_margin: float = math.inf        # first destabilising delay (scaled)
    horizon: float = math.inf             # switches are complete up to this delay

    def critical_delays(self, k: int) -> np.ndarray:
        """tau_{n,k,r}, r = 0..m_r, of crossing frequency k (40)."""
        return np.array([s.delay for s in self.switches
                         if s.frequency == self.crossing_frequencies[k]])

    def delay_to_rad_s(self, delay: float) -> float:
        """Top-drive speed whose blade delay is ``delay`` (scaled): 2 pi / (n_b tau t*)."""
        if delay <= 0.0:
            return math.inf
        return 2.0 * math.pi / (self.n_blades * delay * self.t_star_s)

    def speed_to_delay(self, top_drive_rad_s: float) -> float:
        return 2.0 * math.pi / (self.n_blades * top_drive_rad_s * self.t_star_s)

    @property
    def critical_omega0(self) -> float:
        """Scaled critical speed omega_0 = 2 pi / (n_b * delay margin)."""
        return 2.0 * math.pi / (self.n_blades * self.delay_margin)

    @property
    def critical_speed_rad_s(self) -> float:
        """Above this top-drive speed the decoupled axial motion is stable."""
        return self.delay_to_rad_s(self.delay_margin)

    @property
    def critical_speed_rpm(self) -> float:
        return rad_s_to_rpm(self.critical_speed_rad_s)

    @property
    def lowest_stable_speed_rpm(self) -> float:
        """The slowest stable speed: the long-delay end of the last stable window (the
        'lowermost stability switch' of Paper IV section 4.2). If that window is still open
        at ``horizon`` (the delay up to which the m_r switches per frequency are complete),
        this is the speed at the horizon, a bound rather than a switch."""
        return rad_s_to_rpm(self.delay_to_rad_s(self.stable_delay_intervals[-1][1]))

    def stable_speed_bands_rpm(self) -> list[tuple[float, float]]:
        """Stable top-drive speed bands (low, high) in rpm; the first ends at infinity."""
        return sorted((rad_s_to_rpm(self.delay_to_rad_s(b)),
                       rad_s_to_rpm(self.delay_to_rad_s(a)))
                      for a, b in self.stable_delay_intervals)

    def is_stable_at(self, top_drive_rpm: float) -> bool:
        tau = self.speed_to_delay(rpm_to_rad_s(top_drive_rpm))
        return any(a <= tau < b for a, b in self.stable_delay_intervals)


# ---- modal data ---------------------------------------------------------------------------
def modal_data(p: LumpedParameters) -> tuple[np.ndarray, np.ndarray]:
    """(omega_j, V_nj^2) of (27)-(31), descending in omega, with V^T A1 V = I."""
    a1, _, k = scaled_axial_matrices(p)
    lam, vec = eigh(k, a1)
    order = np.argsort(lam)[::-1]
    return np.sqrt(lam[order]), vec[-1, order] ** 2


def _q(w: float, om: np.ndarray, wt: np.ndarray, d_hat: float, nba: float) -> float:
    """q(w) = F(w) / |prod p_j(jw)|^2 = 1 + 2 n_b alpha sum_j V_nj^2 Re(1 / p_j(jw))."""
    delta = (om - w) * (om + w)
    c = d_hat * w
    return 1.0 + 2.0 * nba * float(np.sum(wt * delta / (delta * delta + c * c)))


def _dq(w: float, om: np.ndarray, wt: np.ndarray, d_hat: float, nba: float) -> float:
    delta = (om - w) * (om + w)
    c = d_hat * w
    den = delta * delta + c * c
    ddelta, dc = -2.0 * w, d_hat
    return 2.0 * nba * float(np.sum(wt * (ddelta * den - delta * (2 * delta * ddelta
                                                                    + 2 * c * dc)) / den ** 2))


def transfer(s: complex, om, wt, d_hat, nba) -> tuple[complex, complex]:
    """G(s) = B(s) / prod p_j(s) and dG/ds."""
    p = s * s + d_hat * s + om * om
    dp = 2.0 * s + d_hat
    return nba * complex(np.sum(wt / p)), -nba * complex(np.sum(wt * dp / (p * p)))


def crossing_frequencies(om: np.ndarray, wt: np.ndarray, d_hat: float,
                         nba: float) -> np.ndarray:
    """Positive roots of F (37), descending."""
    if d_hat <= 0.0:
        raise ValueError("the bracketing needs d_hat > 0 (F has double roots at omega_j "
                         "without damping)")
    top = 4.0 * math.sqrt(2.0 * nba * float(np.sum(wt)) + float(np.max(om)) ** 2)
    grid = [np.linspace(1e-6 * float(np.min(om)), top, 4000),
            np.geomspace(1e-4 * float(np.min(om)), top, 2000)]
    eps = np.geomspace(1e-15, 0.2, 300)
    for o in om:
        grid += [o * (1.0 - eps), o * (1.0 + eps), np.array([o])]
        width = d_hat * o          # the resonance's own width
        grid.append(o + width * np.linspace(-20.0, 20.0, 81))
    w = np.unique(np.concatenate(grid))
    w = w[w > 0.0]
    args = (om, wt, d_hat, nba)
    vals = np.array([_q(x, *args) for x in w])
    roots = []
    for i in np.flatnonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0):
        roots.append(brentq(_q, w[i], w[i + 1], args=args, xtol=1e-15, rtol=1e-15,
                            maxiter=200))
    roots += list(w[vals == 0.0])
    return np.array(sorted(set(roots), reverse=True))


def crossing_direction(w: float, om, wt, d_hat, nba) -> int:
    """sign F'(w) at a root of F (F' = |prod p|^2 q' there)."""
    return 1 if _dq(w, om, wt, d_hat, nba) > 0.0 else -1


def crossing_phase(w: float, om, wt, d_hat, nba) -> float:
    """theta = angle(B / A) at s = j w, in [0, 2 pi) (39)."""
    g, _ = transfer(1j * w, om, wt, d_hat, nba)
    return float(np.mod(np.angle(g / (1.0 + g)), 2.0 * math.pi))


def root_velocity(w: float, tau: float, om, wt, d_hat, nba) -> complex:
    """ds/dtau of the root s = j w of P(s, tau) by implicit differentiation of
    H = P / prod p_j = 1 + G(s) (1 - exp(-s tau)) (independent of F')."""
    s = 1j * w
    g, dg = transfer(s, om, wt, d_hat, nba)
    e = np.exp(-s * tau)
    return -(g * s * e) / (dg * (1.0 - e) + g * tau * e)


def stable_windows(switches: list[Switch]) -> tuple[list[tuple[float, float]], float]:
    """Stable delay windows from the sorted switches, starting stable at tau = 0."""
    unstable_pairs = 0
    windows, start, margin = [], 0.0, math.inf
    for sw in switches:
        before = unstable_pairs
        unstable_pairs = max(0, unstable_pairs + sw.direction)
        if before == 0 and unstable_pairs > 0:
            windows.append((start, sw.delay))
            margin = min(margin, sw.delay)
        elif before > 0 and unstable_pairs == 0:
            start = sw.delay
    if unstable_pairs == 0:
        windows.append((start, math.inf))
    return windows, margin


def analyse(p: LumpedParameters, m_r: int = 10) -> StabilityResult:
    """Walton-Marshall analysis of (43) for derived parameters ``p``."""
    om, wt = modal_data(p)
    d_hat, nba = p.d_hat, p.nb_alpha
    ws = crossing_frequencies(om, wt, d_hat, nba)
    dirs = np.array([crossing_direction(w, om, wt, d_hat, nba) for w in ws], dtype=int)
    phases = np.array([crossing_phase(w, om, wt, d_hat, nba) for w in ws])
    switches = sorted((Switch(float((th + 2.0 * math.pi * r) / w), float(w), int(d), r)
                       for w, d, th in zip(ws, dirs, phases) for r in range(m_r + 1)),
                      key=lambda s: s.delay)
    # all switches are known only up to the smallest tau_{k, m_r}: count up to there
    horizon = min(((th + 2.0 * math.pi * m_r) / w for w, th in zip(ws, phases)),
                  default=math.inf)
    switches = [sw for sw in switches if sw.delay <= horizon]
    windows, margin = stable_windows(switches)
    if windows and windows[-1][1] == math.inf and windows[-1][0] > 0.0:
        windows[-1] = (windows[-1][0], horizon)
    return StabilityResult(
        section=p.section.name, n=p.n, with_bha=p.with_bha,
        mud_viscosity_pa_s=p.section.mud_viscosity_pa_s, t_star_s=p.t_star_s,
        n_blades=p.bit_rock.n_blades, d_hat=d_hat, nb_alpha=nba, eigenfrequencies=om,
        modal_weights=wt, crossing_frequencies=ws, directions=dirs, phases=phases,
        switches=tuple(switches), stable_delay_intervals=tuple(windows), delay_margin=margin,
        horizon=horizon)


def axial_stability(section: str | WellSection, n: int, with_bha: bool = False, *,
                    mud_viscosity_pa_s: float | None = None, m_r: int = 10) -> StabilityResult:
    """Decoupled axial stability of a Table 1 section with n blocks (Paper IV section 3.1)."""
    return analyse(derive(section, n, with_bha, mud_viscosity_pa_s=mud_viscosity_pa_s), m_r)


def characteristic_polynomials(p: LumpedParameters):
    """Expanded A(s), B(s) (ascending coefficients in s) and F(w) (ascending in w) of
    (33) and (37); for cross-checks at small n only (coefficients overflow precision)."""
    om, wt = modal_data(p)
    ps = [np.array([o * o, p.d_hat, 1.0]) for o in om]
    prod = np.array([1.0])
    for q in ps:
        prod = npoly.polymul(prod, q)
    b = np.zeros(1)
    for j in range(len(ps)):
        term = np.array([p.nb_alpha * wt[j]])
        for i, q in enumerate(ps):
            if i != j:
                term = npoly.polymul(term, q)
        b = npoly.polyadd(b, term)
    a = npoly.polyadd(prod, b)

    def at_jw(c):      # coefficients of c(jw) as a complex polynomial in w
        return c * (1j) ** np.arange(len(c))

    f = npoly.polysub(npoly.polymul(at_jw(a), np.conj(at_jw(a))),
                      npoly.polymul(at_jw(b), np.conj(at_jw(b)))).real
    return a, b, f
