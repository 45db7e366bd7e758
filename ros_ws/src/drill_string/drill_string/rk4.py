"""Classic fourth-order Runge-Kutta for the drilling model, for the convergence study.

The same model as ``simulate`` (Tengesdal (2021), Paper IV eqs. (21)-(26) with the bit-rock
law of section 2.3) on the first-order state [z, z', theta, theta']. RK4 cannot carry the
set-valued stick reactions inside a step, so stick is decided at step boundaries: a bit that
would turn backwards is stopped (its angular speed projected to zero, its axial speed too,
section 5.1.3) and held with zero acceleration until the string's torque exceeds what the
rock resists; the axial stick of section 5.1.2 is handled the same way. This is first order
at the events, as any event-free explicit scheme is (thesis section 2.5.5).
"""
from __future__ import annotations

import numpy as np

from .bit_rock import BladeHistory, ScaledBitRock
from .lumped_model import scaled_axial_matrices, scaled_torsional_matrices
from .parameters import rpm_to_rad_s


def simulate_rk4(config, duration_s: float, step_s: float | None = None):
    from .simulate import DEFAULT_SCALED_STEP, ROW_COLUMNS, trajectory_from_rows
    p = config.parameters()
    h = (step_s / p.t_star_s) if step_s else DEFAULT_SCALED_STEP
    n = p.n
    law = ScaledBitRock.of(p)
    om0 = p.scaled_speed(rpm_to_rad_s(config.top_drive_rpm))
    v0 = p.scaled_rate(config.block_speed_m_s)
    tau0, d0, w0, t0 = law.nominal(v0, om0)
    ma, ca, ka = scaled_axial_matrices(p)
    mt, ct, kt = scaled_torsional_matrices(p)
    inv_ma, inv_mt = 1.0 / np.diag(ma), 1.0 / np.diag(mt)
    # first-order system matrices: x' = A x + bit terms
    a_sys = np.zeros((4 * n, 4 * n))
    eye = np.eye(n)
    a_sys[0:n, n:2 * n] = eye
    a_sys[n:2 * n, 0:n] = -inv_ma[:, None] * ka
    a_sys[n:2 * n, n:2 * n] = -inv_ma[:, None] * ca
    a_sys[2 * n:3 * n, 3 * n:4 * n] = eye
    a_sys[3 * n:4 * n, 2 * n:3 * n] = -inv_mt[:, None] * kt
    a_sys[3 * n:4 * n, 3 * n:4 * n] = -inv_mt[:, None] * ct
    iz, izv, ith, ithv = n - 1, 2 * n - 1, 3 * n - 1, 4 * n - 1
    ka_n, ca_n = ka[n - 1], ca[n - 1]
    kt_n, ct_n = kt[n - 1], ct[n - 1]
    m_ax, m_t = ma[n - 1, n - 1], mt[n - 1, n - 1]
    lam, k_ax, k_t, beta = law.wear_flat_depth_m, law.nb_alpha, law.nb_torque_gain, law.beta

    back = 2.0 * tau0
    hist = BladeHistory(law.blade_angle_rad, [-back, 0.0], [-back * om0, 0.0], [-back * v0, 0.0])
    x = np.zeros(4 * n)
    x[izv] = p.scaled_rate(config.initial_bit_axial_speed_m_s)
    x[3 * n:] = (config.initial_rotation_fraction - 1.0) * om0

    def string_force(x):     # spring + damping force on the bit block (perturbation)
        return -(ka_n @ x[0:n] + ca_n @ x[n:2 * n]), -(kt_n @ x[2 * n:3 * n] + ct_n @ x[3 * n:])

    def bit_loads(tau, x, stick_t, stick_a):
        delay, past = hist.lookup(tau, om0 * tau + x[ith])
        depth = v0 * tau + x[iz] - past
        r_ax, r_t = string_force(x)
        if stick_t or stick_a:
            force = r_ax + w0                     # holds the bit: no axial acceleration
        elif depth > 0.0:
            force = k_ax * (depth + (lam if v0 + x[izv] > 0.0 else 0.0))
        else:
            force = 0.0
        if stick_t:
            torque = r_t + t0
        elif depth > 0.0:
            torque = k_t * (depth + (beta * lam if v0 + x[izv] > 0.0 else 0.0))
        else:
            torque = 0.0
        return force, torque, depth, delay

    def rhs(tau, x, stick_t, stick_a):
        force, torque, _, _ = bit_loads(tau, x, stick_t, stick_a)
        dx = a_sys @ x
        dx[izv] -= (force - w0) / m_ax
        dx[ithv] -= (torque - t0) / m_t
        return dx

    steps = max(1, int(round(duration_s / (h * p.t_star_s))))
    out = np.empty((steps, ROW_COLUMNS))
    flags = np.zeros((steps, 3), bool)
    stick_t = stick_a = False
    tau = 0.0
    for k in range(steps):
        k1 = rhs(tau, x, stick_t, stick_a)
        k2 = rhs(tau + 0.5 * h, x + 0.5 * h * k1, stick_t, stick_a)
        k3 = rhs(tau + 0.5 * h, x + 0.5 * h * k2, stick_t, stick_a)
        k4 = rhs(tau + h, x + h * k3, stick_t, stick_a)
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        tau += h
        # events at the step boundary
        force, torque, depth, delay = bit_loads(tau, x, False, False)
        r_ax, r_t = string_force(x)
        if stick_t:
            if r_t + t0 > torque:             # string torque beats the rock: slip
                stick_t = False
        elif om0 + x[ithv] < 0.0:
            stick_t = True
        if stick_t:
            x[ithv] = -om0
            x[izv] = -v0
        else:
            drive = r_ax + w0
            if stick_a:
                if drive > k_ax * (depth + lam) or drive < k_ax * depth or depth <= 0.0:
                    stick_a = False
            elif v0 + x[izv] < 0.0 and depth > 0.0 and drive >= k_ax * depth:
                stick_a = True
            if stick_a:
                x[izv] = -v0
        force, torque, depth, delay = bit_loads(tau, x, stick_t, stick_a)
        bit_pos = v0 * tau + x[iz]
        hist.append(tau, om0 * tau + x[ith], bit_pos)
        out[k] = (tau, om0 + x[ithv], v0 + x[izv], bit_pos, force, torque, depth, delay,
                  n * n * p.l[0] * (0.0 - x[2 * n]), p.stiffness_factor * p.a[0] * (0.0 - x[0]),
                  v0 * tau, om0)
        flags[k] = (stick_t, stick_a, depth <= 0.0)
    ts = p.t_star_s
    return trajectory_from_rows(
        p, out, flags, (v0, om0, w0, t0),
        dict(section=p.section.name, n=n, with_bha=p.with_bha, scheme="rk4", step_s=h * ts,
             scaled_step=h, t_star_s=ts, omega0=om0, v0=v0, top_drive_rad_s=om0 / ts))
