"""What one supervisor step returns: its command, how it was found (the fallback taken, the
solver's status and reasons) and its plan (SI units throughout). Plain module (no rclpy)."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from drill_core.input_layout import U_SIZE


class Fallback(str, Enum):
    """What a step fell back to (a str: NmpcStatus.fallback carries the value)."""
    NONE = "none"          # the plan of a solve with the configured constraints
    RELAXED = "relaxed"    # a retry with the relaxed constraint set
    HOLD = "hold"          # no usable solve: the last input held (Supervisor._hold)


@dataclass
class SolveResult:
    """Outcome of one supervisor step (SI units throughout)."""
    u: np.ndarray                          # command to apply from t_k: [u_r m, q_c m^3/s, q_bpp m^3/s, p_in Pa]
    success: bool                          # True when u comes from a converged solve
    fallback: Fallback
    status: str                            # solver return status (last attempt)
    iterations: int                        # solver iterations (last attempt)
    solve_time_s: float                    # wall time of the step, retries included
    cost: float                            # optimal cost (NaN when holding)
    slacks: dict = field(default_factory=dict)      # largest slack over the horizon per constraint, SI
    predicted_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))   # 0, t_s, ..., N t_s
    predicted: dict = field(default_factory=dict)   # name -> array over predicted_time_s
    planned_inputs: np.ndarray = field(default_factory=lambda: np.zeros((0, U_SIZE)))  # N x 4, u_j
    reference: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))       # (N+1) x 3, y_ref,j
    integral: np.ndarray = field(default_factory=lambda: np.zeros(0))             # NMPC1 e_0 [span s]
    configuration: str = ""
    choke_flow_m3s: float = float("nan")   # predicted choke flow under u at t_k (pressure-loop feedforward)
    hold_choke_dp_pa: float = float("nan")  # on a hold: the choke dp to hold on the choke's pressure
                                            # loop (Supervisor.rest_choke_dp when the holds began) [Pa]
    reasons: tuple[str, ...] = ()           # what else the step met: each unusable attempt and why,
                                            # a friction clamp, a warm start rolled out, a shortened step
