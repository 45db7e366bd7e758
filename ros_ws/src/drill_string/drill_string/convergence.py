"""Step-size convergence of the integration schemes against a fine-step reference.

As in the thesis' comparison of RK4 and generalised-alpha (section 3.3 and Paper III): each
scheme runs one configuration at a ladder of steps; the error is measured against a
reference run at a much finer step, on a common sample grid, for the bit speed and for the
bit's axial advance; the wall time per simulated second is measured alongside.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from .simulate import DrillingConfig, Trajectory, simulate


@dataclass(frozen=True)
class ConvergenceRow:
    scheme: str
    scaled_step: float
    step_s: float
    max_bit_speed_error_rad_s: float
    max_bit_depth_error_m: float
    wall_s_per_simulated_s: float
    order: float | None          # observed order of the speed error vs the previous row


def _errors(run: Trajectory, ref: Trajectory, grid: np.ndarray) -> tuple[float, float]:
    speed = np.interp(grid, run.time_s, run.bit_speed_rad_s) \
        - np.interp(grid, ref.time_s, ref.bit_speed_rad_s)
    depth = np.interp(grid, run.time_s, run.bit_depth_m) \
        - np.interp(grid, ref.time_s, ref.bit_depth_m)
    return float(np.max(np.abs(speed))), float(np.max(np.abs(depth)))


def convergence_study(config: DrillingConfig, duration_s: float,
                      scaled_steps=(0.02, 0.01, 0.005, 0.0025, 0.00125),
                      schemes=("newmark", "generalized_alpha", "rk4"),
                      reference_scheme: str = "rk4",
                      reference_scaled_step: float = 2.5e-4,
                      samples: int = 400) -> tuple[list[ConvergenceRow], float]:
    """Rows per (scheme, step) and the reference run's wall time per simulated second."""
    t_star = config.parameters().t_star_s
    start = time.perf_counter()
    ref = simulate(replace(config, scheme=reference_scheme), duration_s,
                   reference_scaled_step * t_star)
    ref_cost = (time.perf_counter() - start) / duration_s
    grid = np.linspace(0.0, duration_s, samples + 1)[1:]
    grid = grid[grid >= ref.time_s[0]]
    rows: list[ConvergenceRow] = []
    for scheme in schemes:
        previous = None
        for h in scaled_steps:
            start = time.perf_counter()
            run = simulate(replace(config, scheme=scheme), duration_s, h * t_star)
            cost = (time.perf_counter() - start) / duration_s
            e_speed, e_depth = _errors(run, ref, grid)
            order = None
            if previous is not None and e_speed > 0.0 and previous[1] > 0.0:
                order = float(np.log(previous[1] / e_speed) / np.log(previous[0] / h))
            rows.append(ConvergenceRow(scheme, h, h * t_star, e_speed, e_depth, cost, order))
            previous = (h, e_speed)
    return rows, ref_cost


def format_table(rows: list[ConvergenceRow]) -> str:
    """Markdown table of a study."""
    lines = ["| scheme | step (scaled) | step (ms) | max bit-speed error (rad/s) | "
             "max bit-advance error (m) | observed order | wall s per simulated s |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        order = "" if r.order is None else f"{r.order:.2f}"
        lines.append(f"| {r.scheme} | {r.scaled_step:g} | {r.step_s * 1e3:.3g} | "
                     f"{r.max_bit_speed_error_rad_s:.2e} | {r.max_bit_depth_error_m:.2e} | "
                     f"{order} | {r.wall_s_per_simulated_s:.4f} |")
    return "\n".join(lines)
