"""Time simulation of the coupled axial-torsional string with the delayed bit-rock law.

The model is Tengesdal (2021), Paper IV eqs. (21), (22), (24) and (26): perturbations z, theta
of the n blocks about the steady drilling state of section 2.4, time in units of t* = L / c_t,
surface perturbations U (block) and Phi (top drive), the bit forces in total terms (section
2.3) so bit bounce and stick (sections 5.1.2-5.1.3) are part of the model:

* per step, everything but the bit force is one affine map (``time_stepping``); the bit's
  axial force and torque at the end of the step then follow from scalar solves that respect
  the rock's unilateral contact, the wear-flat engagement (set-valued when the bit is axially
  stuck) and the torsional stick (the bit does not turn backwards; stuck in rotation it
  does not advance);
* the blade delay comes from ``BladeHistory`` with the bit angle predicted with the
  previous step's torque (``corrector=True`` repeats the solve with the corrected angle).

Schemes: ``newmark`` (the paper's, beta = 1/4, gamma = 1/2), ``generalized_alpha`` (Chung and
Hulbert, ``rho_inf``) and ``rk4`` (explicit, on the first-order form, stick handled by
projection at the step boundaries; for the convergence study).

Outputs are SI (``Trajectory``); ``stick_slip_severity``, ``stick_time_fraction`` and
``rate_of_penetration_m_s`` summarise a trajectory.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from .bit_rock import BladeHistory, ScaledBitRock
from .lumped_model import buoyed_weight_n, scaled_axial_matrices, scaled_torsional_matrices
from .parameters import LumpedParameters, WellSection, derive, rad_s_to_rpm, rpm_to_rad_s
from .time_stepping import AlphaCoefficients, affine_step, block_diagonal

SCHEMES = ("newmark", "generalized_alpha", "rk4")
DEFAULT_SCALED_STEP = 2.5e-3   # Delta tau; see docs/drilling.md for the convergence study


@dataclass(frozen=True)
class DrillingConfig:
    """One drilling run: the string, the operating point and the initial perturbation.

    ``initial_bit_axial_speed_m_s`` is added to the bit's nominal axial speed at t = 0
    (Paper IV Fig. 9: 0.1 in scaled units, i.e. 0.1 / t* m/s); ``initial_rotation_fraction``
    sets every block's initial angular speed to that fraction of the top-drive speed
    (Figs. 5-6: 0.5)."""
    section: str | WellSection = "12.25in"
    n_elements: int = 6
    with_bha: bool = True
    top_drive_rpm: float = 120.0
    block_speed_m_s: float = 0.05
    mud_viscosity_pa_s: float | None = None
    initial_bit_axial_speed_m_s: float = 0.0
    initial_rotation_fraction: float = 1.0
    scheme: str = "newmark"
    rho_inf: float = 0.9
    corrector: bool = False

    def parameters(self) -> LumpedParameters:
        return derive(self.section, self.n_elements, self.with_bha,
                      mud_viscosity_pa_s=self.mud_viscosity_pa_s)


def paper_fig9_config(top_drive_rpm: float, **overrides) -> DrillingConfig:
    """Paper IV section 5.3: 12 1/4" with BHA, n = 6, mu = 0.03 Pa s, V0 = 0.05 m/s,
    initial bit axial perturbation 0.1 (scaled), at the given top-drive speed."""
    base = DrillingConfig(section="12.25in", n_elements=6, with_bha=True,
                          top_drive_rpm=top_drive_rpm, block_speed_m_s=0.05,
                          mud_viscosity_pa_s=0.03)
    t_star = base.parameters().t_star_s
    return replace(base, **{"initial_bit_axial_speed_m_s": 0.1 / t_star, **overrides})


@dataclass
class Trajectory:
    """Sampled run, SI. ``bit_depth_m`` is the bit's axial advance since t = 0 and
    ``block_position_m`` the travelling block's (both positive down); ``hook_load_n`` is the
    top spring's tension (the buoyed string weight less what the string pushes on the
    bit and loses to mud drag); ``top_drive_speed_rad_s`` the speed imposed at the top."""
    time_s: np.ndarray
    bit_speed_rad_s: np.ndarray
    bit_axial_speed_m_s: np.ndarray
    bit_depth_m: np.ndarray
    wob_n: np.ndarray
    tob_nm: np.ndarray
    depth_of_cut_m: np.ndarray
    delay_s: np.ndarray
    surface_torque_nm: np.ndarray
    hook_load_n: np.ndarray
    block_position_m: np.ndarray
    top_drive_speed_rad_s: np.ndarray
    torsional_stick: np.ndarray
    axial_stick: np.ndarray
    off_bottom: np.ndarray
    meta: dict = field(default_factory=dict)

    def window(self, start_s: float | None = None, end_s: float | None = None) -> "Trajectory":
        t = self.time_s
        mask = np.ones(t.shape, bool)
        if start_s is not None:
            mask &= t >= start_s
        if end_s is not None:
            mask &= t <= end_s
        kw = {k: (v[mask] if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()}
        return Trajectory(**kw)

    @property
    def rop_m_s(self) -> np.ndarray:
        return self.bit_axial_speed_m_s

    @classmethod
    def concatenate(cls, parts: list["Trajectory"]) -> "Trajectory":
        """One trajectory of consecutive ``parts`` (the first part's ``meta``)."""
        return cls(**{name: np.concatenate([getattr(p, name) for p in parts])
                      for name in TRAJECTORY_FIELDS}, meta=dict(parts[0].meta))


# the sampled arrays of a Trajectory (drill_msgs/DrillingTruth carries them by these names)
TRAJECTORY_FIELDS = tuple(f.name for f in fields(Trajectory) if f.name != "meta")


ROW_COLUMNS = 12     # one sample in scaled units (trajectory_from_rows)


def trajectory_from_rows(p: LumpedParameters, rows: np.ndarray, flags: np.ndarray,
                         nominal: tuple[float, float, float, float], meta: dict) -> Trajectory:
    """The SI trajectory of sampled rows in scaled units: time, bit speed, bit axial speed,
    bit position, bit force, bit torque, depth of cut, delay, top-spring torque and force
    perturbations, block position, top-drive speed (lengths in metres); ``flags`` torsional
    stick, axial stick, off bottom; ``nominal`` the configuration's (v0, omega0, W0, T0)."""
    v0, om0, w0, t0 = nominal
    ts = p.t_star_s
    # the top spring's steady loads: the bit's plus the mud drag on every block (scaled)
    top_force = w0 + p.d_hat * float(np.sum(p.a)) * v0
    top_torque = t0 + p.c_hat * float(np.sum(p.l)) * om0
    return Trajectory(
        time_s=rows[:, 0] * ts,
        bit_speed_rad_s=rows[:, 1] / ts,
        bit_axial_speed_m_s=rows[:, 2] / ts,
        bit_depth_m=rows[:, 3],
        wob_n=rows[:, 4] * p.force_scale_n,
        tob_nm=rows[:, 5] * p.torque_scale_nm,
        depth_of_cut_m=rows[:, 6],
        delay_s=rows[:, 7] * ts,
        surface_torque_nm=(rows[:, 8] + top_torque) * p.torque_scale_nm,
        hook_load_n=buoyed_weight_n(p) - (rows[:, 9] + top_force) * p.force_scale_n,
        block_position_m=rows[:, 10],
        top_drive_speed_rad_s=rows[:, 11] / ts,
        torsional_stick=flags[:, 0].copy(),
        axial_stick=flags[:, 1].copy(),
        off_bottom=flags[:, 2].copy(),
        meta=meta)


def stick_slip_severity(traj: Trajectory, start_s: float | None = None) -> float:
    """(max - min) / mean of the bit speed (0 for steady rotation, about 2 for stick-slip)."""
    w = traj.window(start_s).bit_speed_rad_s
    mean = float(np.mean(w))
    return float((np.max(w) - np.min(w)) / mean) if mean > 0 else math.inf


STICK_SPEED_FRACTION = 0.02


def _stuck(traj: Trajectory) -> np.ndarray:
    """Samples where the bit turns slower than 2 % of the top-drive speed (stuck or creeping
    between short slips)."""
    return traj.bit_speed_rad_s < STICK_SPEED_FRACTION * traj.top_drive_speed_rad_s


def stick_time_fraction(traj: Trajectory, start_s: float | None = None) -> float:
    """Fraction of the time the bit is (nearly) at rest in rotation."""
    return float(np.mean(_stuck(traj.window(start_s))))


def longest_stick_s(traj: Trajectory, start_s: float | None = None) -> float:
    """Longest stretch with the bit (nearly) at rest in rotation."""
    w = traj.window(start_s)
    edges = np.diff(np.concatenate([[0], _stuck(w).astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if starts.size == 0:
        return 0.0
    dt = float(np.median(np.diff(w.time_s))) if w.time_s.size > 1 else 0.0
    return float(np.max(ends - starts)) * dt


def rate_of_penetration_m_s(traj: Trajectory, start_s: float | None = None) -> float:
    """Mean bit advance rate over the window."""
    w = traj.window(start_s)
    span = w.time_s[-1] - w.time_s[0]
    return float((w.bit_depth_m[-1] - w.bit_depth_m[0]) / span) if span > 0 else 0.0


class DrillStringSimulator:
    """Stepping simulator (Newmark or generalised-alpha) for one configuration.

    ``advance(duration_s, top_drive_rpm=..., block_speed_m_s=...)`` runs on and returns the
    samples of that stretch; the surface speeds may change between calls (they enter as the
    perturbations U and Phi of eqs. (24) and (26)). Off bottom the bit turns freely, also
    backwards; on bottom it never turns backwards (Paper IV section 5.1.3)."""

    def __init__(self, config: DrillingConfig, step_s: float | None = None):
        if config.scheme not in ("newmark", "generalized_alpha"):
            raise ValueError("DrillStringSimulator runs 'newmark' or 'generalized_alpha'; "
                             "use simulate(..., scheme='rk4') for RK4")
        self.config = config
        p = self.p = config.parameters()
        self.h = (step_s / p.t_star_s) if step_s else DEFAULT_SCALED_STEP
        self.step_s = self.h * p.t_star_s
        n = self.n = p.n
        self.law = law = ScaledBitRock.of(p)
        self.omega0 = p.scaled_speed(rpm_to_rad_s(config.top_drive_rpm))
        self.v0 = p.scaled_rate(config.block_speed_m_s)
        if self.omega0 <= 0.0:
            raise ValueError("the top drive must turn forward")
        self.tau_n0, self.d0, self.w0, self.t0 = law.nominal(self.v0, self.omega0)
        coeff = (AlphaCoefficients.newmark() if config.scheme == "newmark"
                 else AlphaCoefficients.generalized_alpha(config.rho_inf))
        ma, ca, ka = scaled_axial_matrices(p)
        mt, ct, kt = scaled_torsional_matrices(p)
        e1, en = np.zeros(n), np.zeros(n)
        e1[0], en[-1] = 1.0, 1.0
        self._top_gain_ax = p.stiffness_factor * p.a[0]
        self._top_gain_t = n * n * p.l[0]
        # channels: axial [U, bit force], torsional [Phi, bit torque]
        ax = affine_step(ma, ca, ka, np.column_stack([self._top_gain_ax * e1, -en]), self.h, coeff)
        to = affine_step(mt, ct, kt, np.column_stack([self._top_gain_t * e1, -en]), self.h, coeff)
        st = block_diagonal(ax, to)
        self._T = np.hstack([st.phi, st.g_old, st.g_new[:, [0, 2]]])
        self._g_bit = st.g_new[:, [1, 3]]
        self._mats = (ma, ca, ka, mt, ct, kt)
        # bit entries of s = [z, z', z'', theta, theta', theta'']
        self._iz, self._izv = n - 1, 2 * n - 1
        self._ith, self._ithv = 4 * n - 1, 5 * n - 1
        iz, ith = self._iz, self._ith
        self._gq_a, self._gv_a = self._g_bit[iz, 0], self._g_bit[self._izv, 0]
        self._gq_t, self._gv_t = self._g_bit[ith, 1], self._g_bit[self._ithv, 1]
        # augmented vector [s (6n), U0, f0, Phi0, T0', U1, Phi1]
        self._x = np.zeros(6 * n + 6)
        self._init_state()

    # ---- state -----------------------------------------------------------------------
    def _init_state(self):
        c, n = self.config, self.n
        q_ax, q_t = np.zeros(n), np.zeros(n)
        v_ax = np.zeros(n)
        v_ax[-1] = self.p.scaled_rate(c.initial_bit_axial_speed_m_s)
        v_t = np.full(n, (c.initial_rotation_fraction - 1.0) * self.omega0)
        blade = self.law.blade_angle_rad
        back = 2.0 * self.tau_n0
        self.hist = BladeHistory(blade, [-back, 0.0], [-back * self.omega0, 0.0],
                                 [-back * self.v0, 0.0])
        self.tau = 0.0
        self.U = 0.0
        self.Phi = 0.0
        self._du = self._dphi = 0.0      # surface speed commands minus the nominal ones
        # bit forces at tau = 0 (history nominal: depth d0)
        eng = 1.0 if self.v0 + v_ax[-1] > 0.0 else 0.0
        w = self.law.wob(self.d0, eng)
        t = self.law.tob(self.d0, eng)
        self.f_ax, self.f_t = w - self.w0, t - self.t0
        ma, ca, ka, mt, ct, kt = self._mats
        en = np.zeros(n)
        en[-1] = 1.0
        a_ax = np.linalg.solve(ma, -ca @ v_ax - ka @ q_ax - en * self.f_ax)
        a_t = np.linalg.solve(mt, -ct @ v_t - kt @ q_t - en * self.f_t)
        self._x[:6 * n] = np.concatenate([q_ax, v_ax, a_ax, q_t, v_t, a_t])
        self._row = np.array([0.0, self.omega0 + v_t[-1], self.v0 + v_ax[-1], 0.0, w, t, self.d0,
                              self.tau_n0, 0.0, 0.0, 0.0, self.omega0])
        self._flags = np.zeros(3, bool)

    # ---- bit solves --------------------------------------------------------------------
    def _axial(self, delta_free: float, v_free: float, rotating: bool):
        """Total axial bit force F and (depth, engagement, axially stuck, off bottom)."""
        law, gq, gv = self.law, self._gq_a, self._gv_a
        if delta_free <= 0.0:
            return 0.0, delta_free, 0.0, False, True
        if not rotating:
            force = v_free / -gv if v_free > 0.0 else 0.0
            depth = delta_free + gq * force
            eng = min(1.0, max(0.0, (force / law.nb_alpha - max(depth, 0.0))
                               / law.wear_flat_depth_m))
            return force, depth, eng, force > 0.0, False
        k, lam = law.nb_alpha, law.wear_flat_depth_m
        denom = 1.0 - k * gq
        force = k * (delta_free + lam) / denom
        depth = delta_free + gq * force
        if v_free + gv * force > 0.0:
            if depth > 0.0:
                return force, depth, 1.0, False, False
            force = delta_free / -gq           # contact held at zero depth
            return force, 0.0, force / (k * lam), False, False
        force = k * delta_free / denom
        if v_free + gv * force < 0.0:
            return force, delta_free + gq * force, 0.0, False, False
        force = v_free / -gv                    # axially stuck: wear flats carry the rest
        depth = delta_free + gq * force
        eng = min(1.0, max(0.0, (force / k - depth) / lam))
        return force, depth, eng, True, False

    def _rock_torque(self, depth: float, eng: float, off: bool) -> float:
        if off:
            return 0.0
        law = self.law
        return law.nb_torque_gain * (max(depth, 0.0) + law.beta * law.wear_flat_depth_m * eng)

    def _solve_bit(self, pred, tau1, torque_guess):
        """Bit force and torque at the end of the step, given the prediction without them."""
        x = pred
        zq, zv = x[self._iz], x[self._izv]
        thq, thv = x[self._ith], x[self._ithv]
        angle = self.omega0 * tau1 + thq + self._gq_t * torque_guess
        delay, past = self.hist.lookup(tau1, angle)
        delta_free = self.v0 * tau1 + zq - self._gq_a * self.w0 - past
        v_free = self.v0 + zv - self._gv_a * self.w0
        force, depth, eng, stick_a, off = self._axial(delta_free, v_free, True)
        torque = self._rock_torque(depth, eng, off)
        w_free = self.omega0 + thv - self._gv_t * self.t0
        stick_t = False
        if not off and w_free + self._gv_t * torque < 0.0:
            stick_t = True
            torque = w_free / -self._gv_t
            force, depth, eng, stick_a, off = self._axial(delta_free, v_free, False)
        return force, torque, depth, delay, stick_t, stick_a, off

    # ---- stepping ------------------------------------------------------------------------
    def advance(self, duration_s: float, top_drive_rpm: float | None = None,
                block_speed_m_s: float | None = None, *,
                top_drive_rad_s: float | None = None) -> Trajectory:
        """Run ``duration_s`` further (rounded to whole steps) and return its samples.

        A speed given here holds until another is given; ``None`` keeps the last command
        (initially the configuration's speeds). The top-drive speed in rpm or rad/s, not
        both."""
        p, n, h = self.p, self.n, self.h
        steps = max(1, int(round(duration_s / self.step_s)))
        if top_drive_rpm is not None:
            if top_drive_rad_s is not None:
                raise ValueError("give the top-drive speed in rpm or in rad/s, not both")
            top_drive_rad_s = rpm_to_rad_s(top_drive_rpm)
        if block_speed_m_s is not None:
            self._du = p.scaled_rate(block_speed_m_s) - self.v0
        if top_drive_rad_s is not None:
            self._dphi = p.scaled_speed(top_drive_rad_s) - self.omega0
        du, dphi = self._du, self._dphi
        out = np.empty((steps, ROW_COLUMNS))
        flags = np.zeros((steps, 3), bool)
        T, gbit, x, hist = self._T, self._g_bit, self._x, self.hist
        ns = 6 * n
        i_top = 3 * n
        i_zacc, i_tacc = 3 * n - 1, 6 * n - 1
        gain_t, gain_ax = self._top_gain_t, self._top_gain_ax
        torque_prev = self.f_t
        v0, om0, w0, t0 = self.v0, self.omega0, self.w0, self.t0
        corrector = self.config.corrector
        fvec = np.empty(2)
        for k in range(steps):
            tau1 = self.tau + h
            U1, Phi1 = self.U + du * h, self.Phi + dphi * h
            x[ns:] = (self.U, self.f_ax, self.Phi, self.f_t, U1, Phi1)
            pred = T @ x
            force, torque, depth, delay, st, sa, off = self._solve_bit(pred, tau1, torque_prev)
            if corrector:
                force, torque, depth, delay, st, sa, off = self._solve_bit(
                    pred, tau1, torque - t0)
            fvec[0], fvec[1] = force - w0, torque - t0
            pred += gbit @ fvec
            # a stuck bit has no acceleration: without this reset the trapezoidal rule
            # carries the impact's acceleration on, alternating in sign every step
            if st:
                pred[i_tacc] = 0.0
            if st or sa:
                pred[i_zacc] = 0.0
            x[:ns] = pred
            self.tau, self.U, self.Phi = tau1, U1, Phi1
            self.f_ax, self.f_t = fvec[0], fvec[1]
            torque_prev = fvec[1]
            zn, zv = pred[n - 1], pred[2 * n - 1]
            thn, thv = pred[4 * n - 1], pred[5 * n - 1]
            bit_pos = v0 * tau1 + zn
            hist.append(tau1, om0 * tau1 + thn, bit_pos)
            out[k] = (tau1, om0 + thv, v0 + zv, bit_pos, force, torque, depth, delay,
                      gain_t * (Phi1 - pred[i_top]), gain_ax * (U1 - pred[0]), v0 * tau1 + U1,
                      om0 + dphi)
            flags[k] = (st, sa, off)
        self._row, self._flags = out[-1].copy(), flags[-1].copy()
        return self._to_si(out, flags)

    def sample(self) -> Trajectory:
        """The one sample at the current time (at t = 0 the initial state)."""
        return self._to_si(self._row[None, :], self._flags[None, :])

    def _to_si(self, out, flags) -> Trajectory:
        return trajectory_from_rows(self.p, out, flags, (self.v0, self.omega0, self.w0, self.t0),
                                    self.meta())

    def meta(self) -> dict:
        p = self.p
        return dict(section=p.section.name, n=p.n, with_bha=p.with_bha,
                    scheme=self.config.scheme, step_s=self.step_s, scaled_step=self.h,
                    t_star_s=p.t_star_s, omega0=self.omega0, v0=self.v0,
                    top_drive_rad_s=self.omega0 / p.t_star_s,
                    top_drive_rpm=rad_s_to_rpm(self.omega0 / p.t_star_s),
                    nominal_wob_n=self.w0 * p.force_scale_n,
                    nominal_tob_nm=self.t0 * p.torque_scale_nm,
                    nominal_depth_of_cut_m=self.d0, nominal_delay_s=self.tau_n0 * p.t_star_s)


def simulate(config: DrillingConfig, duration_s: float, step_s: float | None = None,
             scheme: str | None = None) -> Trajectory:
    """Simulate ``duration_s`` at constant surface speeds; ``step_s`` defaults to
    ``DEFAULT_SCALED_STEP`` t*. ``scheme`` overrides ``config.scheme``."""
    if scheme is not None and scheme != config.scheme:
        config = replace(config, scheme=scheme)
    if config.scheme not in SCHEMES:
        raise ValueError(f"unknown scheme {config.scheme!r}; one of {SCHEMES}")
    if config.scheme == "rk4":
        from .rk4 import simulate_rk4
        return simulate_rk4(config, duration_s, step_s)
    return DrillStringSimulator(config, step_s).advance(duration_s)
