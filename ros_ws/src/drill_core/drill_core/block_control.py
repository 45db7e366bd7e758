"""Block-position controller of the drawworks (paper: linear state-integrator).

The drawworks is commanded to u_b = u_r + s_0 + k_p (u_r - x_s) + k_i * integral(u_r - x_s),
where s_0 = m g F_b / k_eq is the static stretch of the hanging string (feed-forward),
so the string position x_s settles on the reference u_r. Used by the drawworks node
(with measured x_s) and by the estimation model (with the state z1).
"""
from __future__ import annotations


def block_command(reference_m, position_m, integral_m_s, static_stretch_m: float,
                  kp: float, ki_per_s: float):
    """Block position command u_b [m]."""
    error = reference_m - position_m
    return reference_m + static_stretch_m + kp * error + ki_per_s * integral_m_s


def reference_for_command(command_m, position_m, integral_m_s, static_stretch_m: float,
                          kp: float, ki_per_s: float):
    """The reference u_r [m] for which the controller commands ``command_m`` (the law is
    affine in u_r): u_r = (u_b - s_0 + k_p x_s - k_i z) / (1 + k_p)."""
    return (command_m - static_stretch_m + kp * position_m - ki_per_s * integral_m_s) / (1.0 + kp)


def integral_for_command(command_m, reference_m, position_m, static_stretch_m: float,
                         kp: float, ki_per_s: float):
    """The integral z [m s] for which the controller commands ``command_m`` (k_i > 0)."""
    return (command_m - block_command(reference_m, position_m, 0.0, static_stretch_m, kp, ki_per_s)) \
        / ki_per_s


def integral_rate(reference_m, position_m):
    """d/dt of the controller integrator [m]."""
    return reference_m - position_m
