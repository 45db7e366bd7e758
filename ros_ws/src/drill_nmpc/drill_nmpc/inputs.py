"""The supervisor's input vector u = [block reference, choke input, bpp flow, stand-pipe
pressure]: its limits and weights, and the choke input's two meanings (a flow reference, or
the set-point of the choke's pressure loop) at an operating point and in a command.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drill_core.config import Nmpc
from drill_core.input_layout import U_CHOKE, U_SIZE
from drill_nmpc.solve_result import SolveResult



def input_arrays(cfg: Nmpc) -> dict[str, np.ndarray]:
    """The input vectors' limits and weights (min, max, slew, span, move_weight,
    reference_weight), the choke entry the dp set-point's with choke_control pressure."""
    out = {key: np.array(getattr(cfg, f"input_{key}").as_tuple(), dtype=float)
           for key in ("min", "max", "slew", "span", "move_weight", "reference_weight")}
    if cfg.choke_control == "pressure":
        c = cfg.choke_dp_setpoint
        for key, value in (("min", c.minimum_pa), ("max", c.maximum_pa), ("slew", c.slew_pa),
                           ("span", c.span_pa), ("move_weight", c.move_weight),
                           ("reference_weight", c.reference_weight)):
            out[key][1] = value
    return out


def choke_time_constant(cfg: Nmpc) -> float | None:
    """The choke pressure loop's time constant in the prediction [s]; None: the choke is
    on its flow loop (u[U_CHOKE] is a flow reference)."""
    return cfg.choke_dp_setpoint.time_constant_s if cfg.choke_control == "pressure" else None


def choke_input(cfg: Nmpc, choke_flow_m3s: float, choke_dp_pa: float) -> float:
    """The supervisor's choke input u[U_CHOKE] at an operating point: the choke-dp set-point
    with the choke on its pressure loop, else the flow reference."""
    return choke_dp_pa if cfg.choke_control == "pressure" else choke_flow_m3s


@dataclass(frozen=True)
class ChokeCommand:
    """The choke's part of a supervisor command (SI), as drill_msgs/RigCommand carries it."""
    pressure_control: bool
    flow_m3s: float              # flow reference, or the pressure loop's flow feedforward
    dp_ref_pa: float             # pressure loop: set-point at the command's stamp (else 0)
    dp_ref_rate_pa_s: float      # pressure loop: its ramp to the next planned set-point


def choke_command(cfg: Nmpc, result: SolveResult, fallback_flow_m3s: float) -> ChokeCommand:
    """What the choke is told for a supervisor result: on the pressure loop u[U_CHOKE] is the
    set-point, ramped toward the next planned one, with the predicted choke flow (the
    operating point's ``fallback_flow_m3s`` before any solve predicted one) as feedforward.
    On a hold the choke on its flow loop goes to its pressure loop at the held choke dp
    (the held flow reference its feedforward) until a solve succeeds again."""
    u = np.asarray(result.u, dtype=float)
    if cfg.choke_control != "pressure":
        if result.fallback == "hold" and math.isfinite(result.hold_choke_dp_pa):
            return ChokeCommand(True, float(u[U_CHOKE]), float(result.hold_choke_dp_pa), 0.0)
        return ChokeCommand(False, float(u[U_CHOKE]), 0.0, 0.0)
    plan = np.asarray(result.planned_inputs, dtype=float).reshape(-1, U_SIZE)
    rate = float(plan[1, U_CHOKE] - u[U_CHOKE]) / cfg.sample_time_s if plan.shape[0] > 1 else 0.0
    flow = result.choke_flow_m3s if math.isfinite(result.choke_flow_m3s) else fallback_flow_m3s
    return ChokeCommand(True, float(flow), float(u[U_CHOKE]), rate)
