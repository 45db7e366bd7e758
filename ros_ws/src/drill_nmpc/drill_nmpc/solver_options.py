"""Options of the NLP solvers the supervisor can use (CasADi nlpsol plugins).

sqpmethod (Gauss-Newton SQP, HPIPM QP with the stage structure given explicitly) is the
default; ipopt and fatrop were measured against it (docs/nmpc.md section 4). ``extra``
overrides any option (dicts merged one level deep).
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Structure:
    """The stage structure of the NLP (FATROP / HPIPM): per stage the numbers of states,
    controls (slacks included) and path rows, and which rows are equalities."""
    N: int
    nx: list
    nu: list
    ng: list
    equality: list


def hpipm_options(s: Structure) -> dict:
    """HPIPM, the structure-exploiting interior-point QP solver (Riccati), on the stages;
    up to 100 iterations (a QP without multipliers to start from has taken 45, docs/nmpc.md
    section 4)."""
    return {"N": s.N, "nx": s.nx, "nu": s.nu, "ng": s.ng, "error_on_fail": False,
            "hpipm": {"mode": "speed", "iter_max": 100, "res_g_max": 1e-6, "res_b_max": 1e-6,
                      "res_d_max": 1e-6, "res_m_max": 1e-6}}


def solver_options(name: str, max_iterations: int, structure: Structure, hessian: str,
                   expand: bool, extra: dict) -> dict:
    """nlpsol options of plugin ``name``."""
    extra = dict(extra)
    s = structure
    opts: dict = {"error_on_fail": False}
    if name in ("ipopt", "sqpmethod"):
        opts["expand"] = expand
    if name == "ipopt":
        opts["ipopt"] = {"print_level": 0, "sb": "yes", "max_iter": max_iterations, "tol": 1e-6,
                         "acceptable_tol": 1e-4, "acceptable_iter": 5,
                         "warm_start_init_point": "yes", "warm_start_bound_push": 1e-6,
                         "warm_start_mult_bound_push": 1e-6, "mu_init": 1e-3,
                         "nlp_scaling_method": "none"}
        opts["print_time"] = False
    elif name == "fatrop":
        opts.update({"structure_detection": "manual", "N": s.N, "nx": s.nx, "nu": s.nu,
                     "ng": s.ng, "equality": s.equality,
                     "fatrop": {"print_level": 0, "max_iter": max_iterations, "tolerance": 1e-6,
                                "mu_init": 1e-2},
                     "print_time": False})
    elif name == "sqpmethod":
        qp = extra.pop("qpsol", "hpipm")
        if qp == "hpipm":
            qp_opts = hpipm_options(s)
        elif qp == "qrqp":
            qp_opts = {"print_iter": False, "print_header": False, "error_on_fail": False}
        else:
            qp_opts = {"error_on_fail": False}
        opts.update({"qpsol": qp, "qpsol_options": qp_opts,
                     "max_iter": max_iterations, "print_header": False, "print_iteration": False,
                     "print_status": False, "print_time": False,
                     "tol_pr": 1e-6, "tol_du": 1e-6})
        if hessian == "exact":
            opts["convexify_strategy"] = "eigen-clip"
    else:
        raise ValueError(f"unknown solver {name!r}")
    for key, value in extra.items():
        if isinstance(value, dict) and isinstance(opts.get(key), dict):
            opts[key] = {**opts[key], **value}
        else:
            opts[key] = value
    return opts
