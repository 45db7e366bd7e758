"""Estimation model shared by the UKF and the NMPC (paper eqs. 45-48; docs/design.md §5).

The truth-plant equations (drill_core.hydraulics) with the annular friction replaced
by a law with random-walk parameters theta_i (config ``annular_friction_law``):

* ``quadratic``: F_i = theta_i |v_e,i| v_e,i, v_e,i = q_i / A_f,i - K_c v_s (eq. 46 with
  the physical clinging sign), theta_i in Pa s^2/m^2;
* ``scaled_rheology``: F_i = theta_i F_nom,i(q_i, v_s), F_nom,i the Herschel-Bulkley
  friction of path i from the well description (mud report, the truth's function family,
  drill_core.rheology) with its yield jump smoothed over a wider velocity for the RK4
  steps, tabulated (:class:`NominalFriction`); theta_i ~ 1 is a factor.

plus the block-position controller in place of the drawworks lag, optionally a random-walk
density offset delta_rho (the mud's true density less the report's: every hydrostatic
column, annulus and string, is (rho + delta_rho) g h; docs/mismatch.md), optionally a
random-walk factor theta_s on the string's friction of the mud report, optionally a
random-walk factor kappa_beta on the effective bulk modulus (mud and wellbore) of the
report, and optionally an
unmeasured influx into the bottom volume (input disturbance on BHP, NMPC2).

State  x = [z1 m, z2 m/s, z3 m s, p_1, q_2, p_2, ..., q_n, p_n, q_d, p_I, theta_2..theta_n
          (, delta_rho) (, theta_s) (, kappa_beta) (, d)]
Input  u = [u_r block reference m, q_c choke flow m^3/s, q_bpp m^3/s, p_in pump pressure Pa]
Output y = [z1, p_1 - p_0, p_n, q_d] (q_d only while circulating).
Everything here takes an array namespace ``xp`` so the one definition evaluates on
numpy rows (all sigma points at once) and on CasADi symbols.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from drill_core import hydraulics as hy
from drill_core.backend import CASADI, NUMPY, table
from drill_core.block_control import block_command, integral_rate
from drill_core.config import RigConfig
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE
from drill_core.integrators import euler_step, rk4_step
from drill_core.rheology import wall_stress_magnitude
from drill_core.state_layout import (MEASUREMENT_NAMES, POSITION, VELOCITY, WellboreLayout,  # noqa: F401 (MEASUREMENT_NAMES re-exported)
                                     hydraulic_state_names)
BLOCK_INTEGRAL = "block_integral_m_s"
BOTTOM_INFLUX = "bottom_influx_m3s"
DENSITY_OFFSET = "density_offset_kgm3"    # the mud's true density less the report's
STRING_FRICTION = "string_friction_factor"  # the string's true friction over the report's
BULK_MODULUS = "bulk_modulus_factor"        # the true effective bulk modulus over the report's


class NominalFriction:
    """Nominal annular friction F_nom,i(q_i, v_s) of paths 2..n from the well description.

    F_nom,i = sum over the path's sections of 4 L/d_h tau(q_i/A_f - K_c v_s) (the truth's
    path_pressure_loss), with tau(v) = tau_HB(|v|) tanh(v/v_sm): the Herschel-Bulkley wall
    stress (drill_core.rheology, laminar to turbulent) whose yield jump is smoothed over
    v_sm instead of the truth's v/sqrt(v^2 + v_reg^2) with v_reg = 5 mm/s. The peak flow
    gain of a path is then about 4 L tau_y/(d_h v_sm A_f), so its flow mode's rate scales
    with 1/v_sm (docs/model.md: RK4 stability at the NMPC's and the UKF's steps); tanh makes the
    law exact to 1e-4 from 3 v_sm on. tau depends on a section only through its hydraulic
    diameter, so each distinct section is one cubic B-spline of its relative velocity
    (checked against the exact function on demand, ``max_error_pa`` over the paths).
    """

    CHECK_FLOWS_M3S = np.linspace(-0.06, 0.06, 2401)   # path flows of the gain and the check

    def __init__(self, wm: hy.WellModel, smoothing_mps: float, v_max_mps: float = 8.0):
        self.smoothing_mps = smoothing_mps
        fluid, g = wm.annulus_fluid, wm.geometry
        sections = {sec.hydraulic_diameter_m: sec for path in g.annulus_paths for sec in path}
        outer = np.geomspace(0.5, v_max_mps, 161)[1:]     # uniform 0.5 mm steps below 0.5 m/s
        grid = np.concatenate([-outer[::-1], np.linspace(-0.5, 0.5, 2001), outer])

        def stress(v, sec):
            return np.asarray(wall_stress_magnitude(NUMPY, np.abs(v), fluid, sec), dtype=float) \
                * np.tanh(v / smoothing_mps)

        self._exact = stress
        self.grid = grid                  # the tables' sample points [m/s]
        self._sections = sections
        self._tables = {d: ca.interpolant(f"annulus_stress_{k}", "bspline", [grid], stress(grid, sec))
                        for k, (d, sec) in enumerate(sorted(sections.items()))}
        self._paths = []                  # per path: (4 L/d_h, A_f, K_c, d_h), alike sections merged
        for path in g.annulus_paths:
            merged: dict[tuple, float] = {}
            for sec in path:
                key = (sec.flow_area_m2, sec.clinging, sec.hydraulic_diameter_m)
                merged[key] = merged.get(key, 0.0) + 4.0 * sec.length_m / sec.hydraulic_diameter_m
            self._paths.append(tuple((c, *key) for key, c in merged.items()))
        q = self.CHECK_FLOWS_M3S
        self._gain_flow = 0.5 * (q[1:] + q[:-1])
        self._gain = [np.diff(self.loss(NUMPY, k, q, 0.0)) / np.diff(q) for k in range(len(self._paths))]
        self.peak_flow_gain = tuple(float(np.max(g)) for g in self._gain)

    @functools.cached_property
    def max_error_pa(self) -> float:
        """The tables' largest error against the exact law [Pa], over +-0.06 m^3/s of each
        path's flow at three string speeds (evaluated once, when first asked: a model is
        rebuilt for every stand of a trip, and this check is a third of its build)."""
        q = self.CHECK_FLOWS_M3S
        return max(float(np.max(np.abs(self.loss(NUMPY, k, q, v)
                                       - self._exact_loss(k, q, v, self._sections))))
                   for k in range(len(self._paths)) for v in (-0.5, 0.0, 0.5))

    def peak_gain_near(self, k: int, flow_m3s: float, half_width_m3s: float) -> float:
        """Largest dF_nom/dq of path k + 2 (string still) within +-half_width of ``flow_m3s``."""
        lo = min(flow_m3s - half_width_m3s, self._gain_flow[-1])
        hi = max(flow_m3s + half_width_m3s, self._gain_flow[0])
        near = (self._gain_flow >= lo) & (self._gain_flow <= hi)
        return float(np.max(self._gain[k][near]))

    def _exact_loss(self, k, q, v_s, sections):
        return sum(c * self._exact(q / a - kc * v_s, sections[d]) for c, a, kc, d in self._paths[k])

    def loss(self, xp, k: int, flow_m3s, string_velocity_mps):
        """F_nom of path k + 2 [Pa] (numpy rows or CasADi symbols)."""
        total = 0.0
        for c, a, kc, d in self._paths[k]:
            v = flow_m3s / a - kc * string_velocity_mps
            total = total + c * table(xp, self._tables[d], v, self.grid)
        return total


@dataclass(frozen=True)
class EstimationModel(WellboreLayout):
    """Estimation model of a well: equations' parameters, friction law and state layout."""
    wm: hy.WellModel
    block_kp: float
    block_ki_per_s: float
    with_disturbance: bool
    friction_law: str = "quadratic"
    nominal_friction: NominalFriction | None = field(default=None, compare=False, repr=False)
    with_density_offset: bool = False
    with_string_friction: bool = False
    with_bulk_modulus: bool = False

    @property
    def n(self) -> int:
        return self.wm.n

    # ---- layout (drill_core.state_layout: indices by name)
    def theta_name(self, i: int) -> str:
        """Name of the friction parameter theta_i, i = 2..n, in the law's unit."""
        law = "friction_parameter_{}_pa_s2_m2" if self.friction_law == "quadratic" \
            else "friction_factor_{}"
        return law.format(i)

    @functools.cached_property
    def names(self) -> tuple[str, ...]:
        return (POSITION, VELOCITY, BLOCK_INTEGRAL, *hydraulic_state_names(self.n),
                *(self.theta_name(i) for i in range(2, self.n + 1)),
                *((DENSITY_OFFSET,) if self.with_density_offset else ()),
                *((STRING_FRICTION,) if self.with_string_friction else ()),
                *((BULK_MODULUS,) if self.with_bulk_modulus else ()),
                *((BOTTOM_INFLUX,) if self.with_disturbance else ()))

    def theta(self, i: int) -> int:
        """Index of theta_i, i = 2..n."""
        return self.index(self.theta_name(i))

    @property
    def block_integral(self) -> int:
        return self.index(BLOCK_INTEGRAL)

    def _optional(self, name: str) -> int:
        """Index of an optional state; AttributeError for a model without it."""
        if name not in self.names:
            raise AttributeError(f"model has no {name} state")
        return self.index(name)

    def _value_or(self, x, name: str, absent: float):
        return x[self.index(name)] if name in self.names else absent

    @property
    def density_offset(self) -> int:
        return self._optional(DENSITY_OFFSET)

    def density_offset_of(self, x):
        """The state's density offset [kg/m^3] (0 for a model without it)."""
        return self._value_or(x, DENSITY_OFFSET, 0.0)

    @property
    def string_friction(self) -> int:
        return self._optional(STRING_FRICTION)

    def string_friction_of(self, x):
        """The state's string friction factor [1] (1 for a model without it)."""
        return self._value_or(x, STRING_FRICTION, 1.0)

    @property
    def bulk_modulus(self) -> int:
        return self._optional(BULK_MODULUS)

    def bulk_modulus_of(self, x):
        """The state's bulk modulus factor [1] (1 for a model without it)."""
        return self._value_or(x, BULK_MODULUS, 1.0)

    @property
    def disturbance(self) -> int:
        return self._optional(BOTTOM_INFLUX)

    @functools.cached_property
    def friction_function(self) -> ca.Function:
        """x -> annular friction of paths 2..n [Pa] (annulus_friction as one function)."""
        x = ca.SX.sym("x", self.size)
        return ca.Function("annulus_friction", [x],
                           [ca.vertcat(*annulus_friction(CASADI, self, ca.vertsplit(x)))])

    def state_scale(self) -> np.ndarray:
        """Typical magnitude of each state, for conditioning (bar, 1000 L/min, ...)."""
        s = np.ones(self.size)
        s[self.velocity] = 0.1
        for i in range(1, self.n + 1):
            s[self.pressure(i)] = 1e5
            if i > 1:
                s[self.flow(i)] = 1e-2
        s[self.string_flow] = 1e-2
        s[self.string_pressure] = 1e5
        for i in range(2, self.n + 1):
            s[self.theta(i)] = 1e6 if self.friction_law == "quadratic" else 1.0
        if self.with_density_offset:
            s[self.density_offset] = 10.0
        if self.with_string_friction:
            s[self.string_friction] = 1.0
        if self.with_bulk_modulus:
            s[self.bulk_modulus] = 1.0
        if self.with_disturbance:
            s[self.disturbance] = 1e-3
        return s


def build_estimation_model(config: RigConfig, with_disturbance: bool = False,
                           smoothing_mps: float | None = None,
                           pulled_m: float = 0.0) -> EstimationModel:
    """The shared model of ``config`` with the annular friction law of config/estimator.yaml;
    ``smoothing_mps`` the yield jump's smoothing velocity of scaled_rheology (None: the
    configured ``annular_friction_smoothing_mps``; the NMPC's prediction takes its wider
    ``nmpc.prediction_friction_smoothing_mps``). The bottom influx comes with the bulk
    modulus factor: both explain more return flow than the model's, and without the factor
    every pressure change on a mud softer than the report reads as an influx
    (docs/mismatch.md). ``pulled_m``: the string that much shorter (drill_core.well)."""
    wm = hy.rig_well_model(config, pulled_m)
    est = config.estimator
    law = est.annular_friction_law                # validated by the config (FRICTION_LAWS)
    smoothing = est.annular_friction_smoothing_mps if smoothing_mps is None else smoothing_mps
    nominal = NominalFriction(wm, smoothing) if law == "scaled_rheology" else None
    return EstimationModel(wm, config.actuators.block_kp, config.actuators.block_ki_per_s,
                           with_disturbance, law, nominal, est.estimate_density_offset,
                           est.estimate_string_friction,
                           est.estimate_bulk_modulus or with_disturbance)


def path_friction(xp, em: EstimationModel, k: int, flow_m3s, string_velocity_mps, theta=1.0):
    """Annular friction of path k + 2: theta |v_e| v_e (eq. 46) or theta F_nom [Pa]."""
    if em.friction_law == "quadratic":
        g = em.wm.geometry
        v_e = flow_m3s / g.main_flow_area_m2[k] - g.main_clinging[k] * string_velocity_mps
        return theta * xp.fabs(v_e) * v_e
    return theta * em.nominal_friction.loss(xp, k, flow_m3s, string_velocity_mps)


def annulus_friction(xp, em: EstimationModel, x):
    """Annular friction F_i = theta_i f_i(q_i, v_s) of paths 2..n [Pa]: f_i = |v_e| v_e
    (quadratic, eq. 46) or the nominal HB friction F_nom,i (scaled_rheology)."""
    return [path_friction(xp, em, k, x[em.flow(i)], x[em.velocity], x[em.theta(i)])
            for k, i in enumerate(range(2, em.n + 1))]


def fitted_friction_parameters(em: EstimationModel, flows_m3s, friction_pa,
                               string_velocity_mps: float = 0.0) -> np.ndarray:
    """theta_2..theta_n that reproduce the friction ``friction_pa`` at ``flows_m3s`` (0 where
    the law gives no friction)."""
    out = []
    for k, (q, f) in enumerate(zip(flows_m3s, friction_pa)):
        unit = float(path_friction(NUMPY, em, k, q, string_velocity_mps))
        out.append(float(f) / unit if unit != 0.0 else 0.0)
    return np.array(out)


def friction_flow_gain_bound(em: EstimationModel, x, speed_floor_mps: float) -> np.ndarray:
    """Upper bound of dF_i/dq_i per unit theta [Pa s/m^3] near state ``x`` (flow-mode stiffness):
    quadratic 2 max(|v_e|, floor)/A_f; scaled_rheology the largest gain of F_nom within
    +-floor of the state's v_e (the peak, at v_e = 0, only where the flow is that close)."""
    g = em.wm.geometry
    out = []
    for k, i in enumerate(range(2, em.n + 1)):
        area = g.main_flow_area_m2[k]
        v_e = x[em.flow(i)] / area - g.main_clinging[k] * x[em.velocity]
        if em.friction_law == "quadratic":
            out.append(2.0 * max(abs(v_e), speed_floor_mps) / area)
        else:
            out.append(em.nominal_friction.peak_gain_near(k, area * v_e, area * speed_floor_mps))
    return np.array(out)


def drift(xp, em: EstimationModel, x, u, string_friction_law=None):
    """Deterministic right-hand side of the estimation model, as a list of entries
    (``string_friction_law``: see hydraulics.hydraulic_rates)."""
    wm, n = em.wm, em.n
    z1, z2, z3 = x[em.position], x[em.velocity], x[em.block_integral]
    u_b = block_command(u[U_BLOCK], z1, z3, wm.geometry.static_stretch_m, em.block_kp, em.block_ki_per_s)
    p = [x[em.pressure(i)] for i in range(1, n + 1)]
    q = [x[em.flow(i)] for i in range(2, n + 1)]
    rates = hy.hydraulic_rates(xp, wm, p, q, x[em.string_flow], x[em.string_pressure], z1, z2,
                               u[U_CHOKE], u[U_BPP_FLOW], u[U_PUMP_PRESSURE],
                               annulus_friction(xp, em, x), string_friction_law,
                               em.density_offset_of(x), em.string_friction_of(x),
                               em.bulk_modulus_of(x))
    bottom_influx = 0.0
    if em.with_disturbance:
        bottom_influx = hy.bottom_inflow_rate(wm, x[em.disturbance])
    out = [z2, hy.hoisting_acceleration(wm, z1, z2, u_b), integral_rate(u[U_BLOCK], z1)]
    for i in range(n):
        if i > 0:
            out.append(rates.flow[i - 1])
        out.append(rates.pressure[i] + (bottom_influx if i == n - 1 else 0.0))
    out += [rates.string_flow, rates.string_pressure]
    out += [0.0 * z1] * (n - 1)                       # random-walk theta: no drift
    if em.with_density_offset:
        out.append(0.0 * z1)                          # random-walk density offset
    if em.with_string_friction:
        out.append(0.0 * z1)                          # random-walk string friction factor
    if em.with_bulk_modulus:
        out.append(0.0 * z1)                          # random-walk bulk modulus factor
    if em.with_disturbance:
        out.append(0.0 * z1)                          # random-walk disturbance
    return out


def measurement_map(em: EstimationModel) -> tuple[np.ndarray, np.ndarray]:
    """h(x) = x[index] - offset (eq. 48) on the estimation model's state
    (WellboreLayout.sensor_map, the plant's sensors' own)."""
    return em.sensor_map(em.wm.well.choke_downstream_pressure_pa)


def measurement(em: EstimationModel, x, circulating: bool):
    """Noise-free measurement y = h(x) (eq. 48), without q_d when circulation is off; its
    first three channels are the NMPC's tracked outputs (numpy or CasADi)."""
    index, offset = measurement_map(em)
    channels = len(index) if circulating else 3
    return [x[int(i)] - float(o) for i, o in zip(index[:channels], offset[:channels])]


def build_discrete_model(em: EstimationModel, step_s: float, substeps: int = 1,
                         integrator: str = "rk4") -> ca.Function:
    """CasADi function F(x, u) -> x after ``step_s`` (``substeps`` steps, inputs held)."""
    x = ca.SX.sym("x", em.size)
    u = ca.SX.sym("u", 4)
    uu = [u[i] for i in range(4)]

    def f(s):
        return ca.vertcat(*drift(CASADI, em, [s[i] for i in range(em.size)], uu))

    one_step = rk4_step if integrator == "rk4" else lambda fn, s, h: euler_step(fn, s, h)
    h = step_s / substeps
    xn = x
    for _ in range(substeps):
        xn = one_step(f, xn, h)
    return ca.Function("estimation_step", [x, u], [xn])


def friction_estimate(em: EstimationModel, x) -> np.ndarray:
    """Estimated annular friction [Pa] of paths 2..n at state ``x`` (numpy), through one
    call of a CasADi function of the state built once per model (a call per path and
    section costs a millisecond per estimate)."""
    return np.asarray(em.friction_function(np.asarray(x, dtype=float)), dtype=float).ravel()
