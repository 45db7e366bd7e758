"""Unscented Kalman filter of the rig (paper eqs. 6-16 and 45-48): filterpy's
``UnscentedKalmanFilter`` with Merwe's scaled sigma points on the shared estimation model
(drill_core.estimation_model), in scaled coordinates, with a batch time update per sensor
frame, measurement switching, per-channel rejection of bad samples and covariance guards.
The design and its reasons: docs/estimator.md. Plain Python (no rclpy).
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import casadi as ca
import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter, unscented_transform
from scipy.stats import chi2

from drill_core.block_control import reference_for_command
from drill_core.compiled import compiled
from drill_core.config import Estimator, RigConfig
from drill_core.estimation_model import (MEASUREMENT_NAMES, EstimationModel, build_discrete_model,
                                         build_estimation_model, friction_estimate,
                                         measurement, measurement_map)
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE
from drill_estimator.initial_state import initial_state
from drill_estimator.model_inputs import BLOCK_INPUTS, holding_block
from drill_estimator.tuning import build_tuning

_JITTER = (1e-12, 1e-10, 1e-8, 1e-6)     # relative to the largest diagonal entry (scaled P)
MIN_BULK_MODULUS_FACTOR = 0.1           # the bulk modulus factor's floor (a mud that stiff is no mud)


@dataclass(frozen=True)
class UpdateResult:
    """Outcome of one measurement update (SI)."""
    accepted: bool                    # False: measurement rejected (NaN/inf), prediction kept
    measurement_names: tuple          # channels used (q_d dropped while not circulating)
    innovation: np.ndarray            # y - y_hat per channel [SI]; NaN if rejected
    nis: float                        # normalised innovation squared; NaN if rejected
    nis_dof: int                      # channels used
    string_flow_observable: bool      # False while circulation is off
    nis_alarm: bool = False           # the windowed NIS exceeded its chi-square bound
    window_nis_per_dof: float = float("nan")  # mean NIS per channel over the current window
    dropped: tuple = ()               # channels left out of this update (NaN/inf values)


def use_bottom_influx(config: RigConfig) -> bool:
    """The disturbance state is estimated when asked for, and always for NMPC2."""
    return bool(config.estimator.estimate_bottom_influx or config.nmpc.configuration == "NMPC2")


class _SigmaPoints(MerweScaledSigmaPoints):
    """Merwe's scaled sigma points, computed without a Python loop over the dimensions."""

    def sigma_points(self, x, P):
        lambda_ = self.alpha ** 2 * (self.n + self.kappa) - self.n
        root = self.sqrt((lambda_ + self.n) * P)      # upper factor: root.T @ root = (n+lambda) P
        return np.vstack([x, x + root, x - root])     # filterpy's order: X0, X0 + U[k], X0 - U[k]


class _BatchUkf(UnscentedKalmanFilter):
    """filterpy's UKF with its extension points filled: the process sigma points go through
    the model in one batch call (``fx`` takes all points), the cross covariance is one
    matrix product."""

    def compute_process_sigmas(self, dt, fx=None, **fx_args):
        self.sigmas_f = fx(self.points_fn.sigma_points(self.x, self.P), **fx_args)

    def cross_variance(self, x, z, sigmas_f, sigmas_h):
        return ((sigmas_f - x) * self.Wc[:, None]).T @ (sigmas_h - z)


class RigUkf:
    """UKF of the rig's estimation model: states, friction parameters (and bottom influx).

    ``initialise(initial_state(y, circulating))`` starts it from one measurement;
    ``predict_frame(inputs)`` advances over N plant steps, one column of inputs per step,
    u = [u_b (or u_r) m, q_c m^3/s, q_bpp m^3/s, p_in Pa]; ``update(y, circulating)`` fuses one sensor sample and returns an
    :class:`UpdateResult`. Properties return SI values; counters: rejected, inflations,
    repairs, resets, skipped_predictions.
    """

    def __init__(self, config: RigConfig, em: EstimationModel | None = None, jit: bool | None = None,
                 block_input: str | None = None):
        self.config = config
        est: Estimator = config.estimator
        self.est = est
        self.block_input = block_input or est.block_input
        if self.block_input not in BLOCK_INPUTS:
            raise ValueError(f"block_input must be one of {BLOCK_INPUTS}")
        self.em = em if em is not None else build_estimation_model(config, use_bottom_influx(config))
        em = self.em
        self.n_x = em.size
        self.plant_steps_per_frame = config.plant.steps_per_frame
        self.model_steps_per_frame = est.model_steps_per_frame
        self.model_step_s = config.plant.sensor_period_s / est.model_steps_per_frame   # RK4 step
        self.scale = em.state_scale()

        self._n_sigma = 2 * self.n_x + 1
        self._jit = est.jit if jit is None else jit       # compile the time update
        self._build_transition()

        # measurement model: channel -> state index; scaled like the state
        self._y_index, self._y_offset = measurement_map(em)
        self._y_scale = self.scale[self._y_index]
        self.tuning = build_tuning(est, em, self.scale)

        points = _SigmaPoints(self.n_x, est.alpha, est.beta, est.kappa_offset - self.n_x,
                              sqrt_method=self._factor)
        self._ukf = _BatchUkf(dim_x=self.n_x, dim_z=4, dt=self.model_step_s, hx=None, fx=None,
                              points=points)
        self._lam_n = est.alpha ** 2 * (self.n_x + points.kappa)   # n_x + lambda
        self._ukf.Q = self.tuning.process.copy()
        self._ukf.R = self.tuning.measurement.copy()

        self._window: deque = deque(maxlen=est.nis_window)
        self._repaired: tuple[np.ndarray, bool] | None = None
        self._x_good = np.zeros(self.n_x)
        self.initialised = False
        self.string_flow_observable = True
        # counters
        self.rejected = 0          # measurement samples rejected (no finite channel)
        self.rejected_channels = 0  # channels left out of an update (NaN/inf)
        self.inflations = 0        # covariance inflations after an NIS alarm
        self.repairs = 0           # covariance square roots that needed jitter/eigenvalue clipping
        self.resets = 0            # non-finite mean/covariance reset to the last good mean and P0
        self.skipped_predictions = 0   # a sigma point went non-finite: mean kept, P grown by Q
        self._nis_bounds: dict[int, float] = {}
        self.predictions = 0
        self.updates = 0

    # ------------------------------------------------------------------ set-up
    def initialise(self, x0, covariance_diagonal=None) -> None:
        """Start from mean ``x0`` (SI) with the configured (or given, SI^2) covariance."""
        x0 = np.asarray(x0, dtype=float)
        if x0.shape != (self.n_x,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"initial state must be {self.n_x} finite values")
        self._ukf.x = x0 / self.scale
        self._ukf.P = self.tuning.initial.copy() if covariance_diagonal is None else \
            np.diag(np.asarray(covariance_diagonal, dtype=float) / self.scale ** 2)
        self._x_good = self._ukf.x.copy()
        self._window.clear()
        self.initialised = True

    def initial_state(self, y, circulating: bool) -> np.ndarray:
        """A steady state of the model consistent with one measurement y (SI) and the
        filter's prior P0: drill_estimator.initial_state."""
        return initial_state(self.em, self.est.friction_tuning.theta_initial, y, circulating,
                             self.tuning.initial * np.outer(self.scale, self.scale),
                             self.est.measurement_noise.bhp_pa ** 2)

    # --------------------------------------------------------------- filtering
    def predict_frame(self, inputs, held: bool = False) -> None:
        """One time update over the N plant steps of ``inputs`` [4 x N] (a column per step).

        The sigma points are drawn once and carried through the interval's RK4 model steps
        (``model_steps_per_frame`` per frame; each takes the mean of its plant-step inputs),
        eqs. 6-8 with the sampling interval N h; the per-plant-step process noise Q
        accumulates to N Q. ``held``: the rig floor's slips hold the string over the frame,
        so each sigma point's string is at rest where that point has it (the held steps of
        :meth:`_build_transition`; the block input ``inputs[0]`` is not used).
        """
        self._require_initialised()
        inputs = np.asarray(inputs, dtype=float)
        if inputs.ndim != 2 or inputs.shape[0] != 4 or inputs.shape[1] < 1:
            raise ValueError(f"inputs must be 4 x N with N >= 1, got shape {inputs.shape}")
        if not np.all(np.isfinite(inputs)):
            raise ValueError(f"non-finite model input {inputs.tolist()}")
        ukf = self._ukf
        plant_steps = inputs.shape[1]
        model_steps = max(1, round(plant_steps * self.model_steps_per_frame
                                   / self.plant_steps_per_frame))
        model_inputs = np.column_stack([chunk.mean(axis=1) for chunk in
                                        np.array_split(inputs, model_steps, axis=1)])
        self._condition()
        self._set_process_noise()
        q_interval = plant_steps * ukf.Q
        transition = self._transition_for(model_steps, held)

        def fx(sigmas):
            propagated = np.asarray(transition(sigmas.T, model_inputs)).T
            self._absorb_repair()            # the sigma draw may have repaired P
            return propagated

        def transform(sigmas, wm, wc, _q, mean_fn, residual_fn):
            if not np.all(np.isfinite(sigmas)):
                # a sigma point left the model's domain: keep the mean, grow P, count it
                self.skipped_predictions += 1
                return ukf.x, ukf.P + q_interval
            return unscented_transform(sigmas, wm, wc, q_interval, mean_fn, residual_fn)

        ukf.predict(UT=transform, fx=fx)
        self._repaired = None   # filterpy redraws the prior's points; the update draws its own
        self._project()
        self.predictions += 1

    def update(self, y, circulating: bool) -> UpdateResult:
        """Measurement update with y = [z1 m, choke dp Pa, BHP Pa, q_d m^3/s] (SI).

        ``y`` may be a sequence or a mapping with the keys of MEASUREMENT_NAMES; while not
        circulating the string-flow channel is ignored (it may be absent or NaN).
        """
        self._require_initialised()
        m = 4 if circulating else 3
        names = MEASUREMENT_NAMES[:m]
        if isinstance(y, dict):
            values = [y.get(name, np.nan) for name in names]
        else:
            values = list(np.asarray(y, dtype=float).ravel()[:m])
        z = np.asarray(values + [np.nan] * (m - len(values)), dtype=float)
        self.string_flow_observable = bool(circulating)
        good = np.isfinite(z)
        if not good.any():
            self.rejected += 1
            return UpdateResult(False, names, np.full(m, np.nan), float("nan"), m, bool(circulating),
                                dropped=names)
        dropped = tuple(n for n, ok in zip(names, good) if not ok)
        self.rejected_channels += len(dropped)
        names = tuple(n for n, ok in zip(names, good) if ok)
        z = z[good]

        ukf = self._ukf
        self._condition()
        ukf.sigmas_f = ukf.points_fn.sigma_points(ukf.x, ukf.P)   # sigma points of the prior
        self._absorb_repair()
        idx, offset, yscale = (a[:m][good] for a in (self._y_index, self._y_offset, self._y_scale))
        gain = self.scale[idx] / yscale
        prior = ukf.x.copy(), ukf.P.copy()
        channels = np.flatnonzero(good)
        ukf.update((z - offset) / yscale, R=self.tuning.measurement[np.ix_(channels, channels)],
                   hx=lambda s: s[idx] * gain - offset / yscale)
        innovation_scaled = np.asarray(ukf.y, dtype=float)
        nis = float(innovation_scaled @ ukf.SI @ innovation_scaled)
        if not (np.isfinite(nis) and np.all(np.isfinite(ukf.x)) and np.all(np.isfinite(ukf.P))):
            ukf.x, ukf.P = prior                 # numerically failed update: keep the prediction
            self.resets += 1
            return UpdateResult(False, names, innovation_scaled * yscale, float("nan"), len(names),
                                bool(circulating), dropped=dropped)
        self.updates += 1

        alarm = False
        self._window.append((nis, len(names)))
        total = sum(v for v, _ in self._window)
        dof = sum(d for _, d in self._window)
        window_mean = total / dof
        if len(self._window) == self._window.maxlen and total > self._nis_bound(dof):
            alarm = True
            ukf.P = ukf.P * self.est.covariance_inflation
            self.inflations += 1
            self._window.clear()
        self._project()
        return UpdateResult(True, names, innovation_scaled * yscale, nis, len(names),
                            bool(circulating), alarm, window_mean, dropped)

    def _build_transition(self) -> None:
        """The discrete model on scaled states: one RK4 model step of ``em``, chained per
        interval (the frame's transition built now, others on first use).

        The held step (the slips hold the string) starts each point's string at rest
        (velocity zero: the slips grip it) on a line that holds it there: the block input
        is the one that holds the point's own position
        (drill_estimator.model_inputs.holding_block), not one block for all points. A
        block at the mean's position would pull every point to the mean: the position's
        variance collapses within seconds and an offset of the mean (an estimated string
        that coasted on as the real one was gripped, an initial position a sensor noise
        off) stays for the whole connection."""
        em = self.em
        F = build_discrete_model(em, self.model_step_s, 1, "rk4")
        s, u = ca.SX.sym("s", self.n_x), ca.SX.sym("u", 4)
        scale = ca.DM(self.scale)
        x = s * scale
        self._step = ca.Function("ukf_step", [s, u], [F(x, self._model_input(x, u)) / scale])
        rest = ca.vertcat(x[:em.velocity], ca.SX(0.0), x[em.velocity + 1:])
        block = holding_block(em, self.block_input, rest[em.position])
        u_held = ca.vertcat(*[block if i == U_BLOCK else u[i] for i in range(4)])
        self._step_held = ca.Function("ukf_step_held", [s, u],
                                      [F(rest, self._model_input(rest, u_held)) / scale])
        self._transition: dict[tuple[int, bool], ca.Function] = {}
        self._transition_for(self.model_steps_per_frame)

    def use_model(self, em: EstimationModel) -> None:
        """Predict with ``em`` from the next frame on: the same states (a string tripped to
        another length, drill_core.well.build_geometry); the mean, the covariance, the
        tuning and the scaling carry over."""
        if em.names != self.em.names:
            raise ValueError(f"a model with other states: {em.names} for {self.em.names}")
        self.em = em
        self._build_transition()

    def recount_position(self, shift_m: float) -> None:
        """The string's position counted from a frame ``shift_m`` [m] away (a stand racked
        or made up: drill_core.tripping.sequence.position_after_connection): the mean's
        position moves, nothing else does (the block integral's input moves with it)."""
        step = shift_m / self.scale[self.em.position]
        self._ukf.x[self.em.position] += step
        self._x_good[self.em.position] += step

    # -------------------------------------------------------------- accessors
    @property
    def mean(self) -> np.ndarray:
        """State mean [SI], in the order of ``state_names``."""
        return self._ukf.x * self.scale

    @property
    def covariance(self) -> np.ndarray:
        """Full state covariance [SI^2]."""
        return self._ukf.P * np.outer(self.scale, self.scale)

    @property
    def covariance_diagonal(self) -> np.ndarray:
        """Variances of the states [SI^2]."""
        return np.diag(self._ukf.P) * self.scale ** 2

    @property
    def state_names(self) -> list[str]:
        return list(self.em.names)

    @property
    def theta(self) -> np.ndarray:
        """Friction parameters theta_2..theta_n (quadratic: Pa s^2/m^2; scaled_rheology: 1)."""
        return self.mean[self.tuning.theta_index]

    @property
    def friction_pa(self) -> np.ndarray:
        """Estimated annular friction of paths 2..n [Pa]."""
        return friction_estimate(self.em, self.mean)

    @property
    def bhp_pa(self) -> float:
        return float(measurement(self.em, self.mean, False)[2])

    @property
    def choke_dp_pa(self) -> float:
        return float(measurement(self.em, self.mean, False)[1])

    @property
    def string_velocity_mps(self) -> float:
        return float(self.mean[self.em.velocity])

    @property
    def bottom_influx_m3s(self) -> float:
        return float(self.mean[self.em.disturbance]) if self.em.with_disturbance else 0.0

    @property
    def counters(self) -> dict[str, int]:
        return {"rejected": self.rejected, "rejected_channels": self.rejected_channels,
                "inflations": self.inflations, "repairs": self.repairs,
                "resets": self.resets, "skipped_predictions": self.skipped_predictions,
                "predictions": self.predictions, "updates": self.updates}

    # ---------------------------------------------------------------- internals
    def _require_initialised(self) -> None:
        if not self.initialised:
            raise RuntimeError("RigUkf.initialise() must be called first")

    def _model_input(self, x, u):
        """Model input [u_r, q_c, q_bpp, p_in] of one sigma point from the filter input ``u``.

        block_input "block_position": u[U_BLOCK] is the drawworks output u_b; the reference that
        makes the model's block controller command u_b at this sigma point, on average over
        the step (z1 taken at mid-step, z1 + z2 h/2, so the held reference adds no damping
        to first order), is u_r = (u_b - s_0 + k_p (z1 + z2 h/2) - k_i z3) / (1 + k_p).
        Then the model's hoisting sees the real drawworks (lag and all) and z3 is only a
        decaying auxiliary state.
        """
        em = self.em
        u_r = u[U_BLOCK]
        if self.block_input == "block_position":
            u_r = reference_for_command(u[U_BLOCK], x[em.position] + 0.5 * self.model_step_s * x[em.velocity],
                                        x[em.block_integral],
                                        em.wm.geometry.static_stretch_m, em.block_kp,
                                        em.block_ki_per_s)
        return ca.vertcat(u_r, u[U_CHOKE], u[U_BPP_FLOW], u[U_PUMP_PRESSURE])

    def _set_process_noise(self) -> None:
        """theta random walk: base std plus the law's theta_motion_std scaled by
        min(1, |v_s| / motion_reference_speed_mps). The quadratic law's coefficient is a
        property of the operating point; it moves fast only when the string moves."""
        tuning = self.tuning
        if not np.any(tuning.theta_motion_var):
            return
        v = self.em.velocity
        speed = abs(float(self._ukf.x[v] * self.scale[v]))
        self._ukf.Q[tuning.theta_block] = tuning.theta_process(
            speed, self.est.motion_reference_speed_mps)

    def _transition_for(self, steps: int, held: bool = False) -> ca.Function:
        """All sigma points (columns, scaled) through ``steps`` model steps with inputs
        [4 x steps]: the chained step function (``held``: the held one) mapped over the
        points (built once per N)."""
        fn = self._transition.get((steps, held))
        if fn is None:
            step = self._step_held if held else self._step
            s, inputs = ca.SX.sym("s", self.n_x), ca.SX.sym("u", 4, steps)
            x = s
            for k in range(steps):
                x = step(x, inputs[:, k])
            name = f"ukf_{'held_' if held else ''}transition_{steps}"
            fn = ca.Function(name, [s, inputs], [x])
            if self._jit:
                fn = compiled([fn], name)[name]
            fn = self._transition[steps, held] = fn.map(f"{name}_all", "serial",
                                                        self._n_sigma, [1], [])
        return fn

    def _condition(self) -> None:
        """Symmetrise P, reset non-finite values, cap each standard deviation."""
        ukf = self._ukf
        if not (np.all(np.isfinite(ukf.x)) and np.all(np.isfinite(ukf.P))):
            self.resets += 1
            ukf.x = self._x_good.copy()
            ukf.P = self.tuning.initial.copy()
            return
        ukf.P = self._capped(0.5 * (ukf.P + ukf.P.T))
        self._x_good = ukf.x.copy()

    def _nis_bound(self, dof: int) -> float:
        bound = self._nis_bounds.get(dof)
        if bound is None:
            bound = self._nis_bounds[dof] = float(chi2.ppf(self.est.nis_alarm_probability, dof))
        return bound

    def _capped(self, P: np.ndarray) -> np.ndarray:
        """P with row/column i scaled so that no standard deviation exceeds its cap (D P D,
        D diagonal with entries <= 1, stays positive semi-definite)."""
        std = np.sqrt(np.maximum(np.diag(P), 0.0))
        cap = self.tuning.max_std
        over = std > cap
        if np.any(over):
            c = np.ones(self.n_x)
            c[over] = cap[over] / std[over]
            P = P * np.outer(c, c)
        return P

    def _factor(self, M: np.ndarray) -> np.ndarray:
        """Upper factor U with U^T U = M; repairs an indefinite M and remembers the repair."""
        try:
            return np.linalg.cholesky(M).T
        except np.linalg.LinAlgError:
            pass
        M = 0.5 * (M + M.T)
        size = max(float(np.max(np.abs(np.diag(M)))), 1e-300)
        eye = np.eye(M.shape[0])
        for rel in _JITTER:
            try:
                root = np.linalg.cholesky(M + rel * size * eye).T
                self._repaired = (root.T @ root, False)
                return root
            except np.linalg.LinAlgError:
                continue
        try:
            w, V = np.linalg.eigh(M)
            floor = 1e-9 * max(float(np.max(w)), 1e-300)
            root = np.linalg.cholesky((V * np.maximum(w, floor)) @ V.T + 1e-12 * size * eye).T
            self._repaired = (root.T @ root, False)
            return root
        except (np.linalg.LinAlgError, ValueError):
            reset = self._lam_n * self.tuning.initial
            self._repaired = (reset, True)
            return np.linalg.cholesky(reset).T      # P0 is positive definite

    def _absorb_repair(self) -> None:
        """Replace P by the repaired covariance if the last square root needed one."""
        if self._repaired is None:
            return
        M, reset = self._repaired
        self._repaired = None
        self._ukf.P = M / self._lam_n
        if reset:
            self.resets += 1
        else:
            self.repairs += 1

    def _project(self) -> None:
        """Keep 0 <= theta <= the law's theta_max, the string friction factor >= 0 and the
        bulk modulus factor > 0 (mean) and the standard deviations capped."""
        x = self._ukf.x
        theta = self.tuning.theta_index
        x[theta] = np.clip(x[theta], 0.0, self.tuning.theta_max)
        if self.em.with_string_friction:
            x[self.em.string_friction] = max(x[self.em.string_friction], 0.0)
        if self.em.with_bulk_modulus:
            x[self.em.bulk_modulus] = max(x[self.em.bulk_modulus], MIN_BULK_MODULUS_FACTOR)
        if np.all(np.isfinite(self._ukf.P)):
            self._ukf.P = self._capped(self._ukf.P)
