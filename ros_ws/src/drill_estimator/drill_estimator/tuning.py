"""The UKF's tuning in its scaled coordinates (s = x / scale): process noise per plant step,
initial covariance, measurement noise, the standard-deviation caps and the friction
parameters' correlated random walk (config/estimator.yaml; docs/estimator.md)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drill_core.config import Estimator
from drill_core.estimation_model import EstimationModel, measurement_map

# the optional random-walk parameters: the model's flag, its index, config/estimator.yaml's
# process and initial standard deviations
RANDOM_WALK_PARAMETERS = (
    ("with_density_offset", "density_offset", "density_offset_process_std_kgm3",
     "initial_density_offset_std_kgm3"),
    ("with_string_friction", "string_friction", "string_friction_process_std",
     "initial_string_friction_std"),
    ("with_bulk_modulus", "bulk_modulus", "bulk_modulus_process_std", "initial_bulk_modulus_std"),
    ("with_disturbance", "disturbance", "bottom_influx_process_std_m3s",
     "initial_bottom_influx_std_m3s"),
)


@dataclass(frozen=True)
class UkfTuning:
    """Covariances of the scaled filter; theta entries index the friction parameters."""
    process: np.ndarray            # Q per plant step
    initial: np.ndarray            # P0
    measurement: np.ndarray        # R, the MEASUREMENT_NAMES channels
    max_std: np.ndarray            # cap of each state's standard deviation
    theta_index: np.ndarray        # states theta_2..theta_n
    theta_correlation: np.ndarray  # correlation matrix of the theta random walks
    theta_max: np.ndarray          # upper bound of the theta means
    theta_base_std: np.ndarray     # theta random-walk std per step at rest
    theta_motion_var: np.ndarray   # added variance per step at full string speed

    @property
    def theta_block(self):
        """Index of the theta-theta block of a covariance."""
        return np.ix_(self.theta_index, self.theta_index)

    def theta_process(self, speed_mps: float, reference_speed_mps: float) -> np.ndarray:
        """The theta block of Q at string speed ``speed_mps``: base std plus the motion std
        scaled by min(1, speed / reference speed), correlated."""
        w = min(1.0, speed_mps / reference_speed_mps)
        std = self.theta_base_std + w * np.sqrt(self.theta_motion_var)
        return np.outer(std, std) * self.theta_correlation


def build_tuning(est: Estimator, em: EstimationModel, scale: np.ndarray) -> UkfTuning:
    """The tuning of config/estimator.yaml for the states of ``em`` scaled by ``scale``."""
    friction = est.friction_tuning
    q_std = np.zeros(em.size)                     # SI standard deviations
    p_std = np.zeros(em.size)
    rig = [em.position, em.velocity, em.block_integral]
    q_std[rig] = est.rig_process_std
    p_std[rig] = est.initial_rig_std
    pressures = [em.pressure(i) for i in range(1, em.n + 1)] + [em.string_pressure]
    flows = [em.flow(i) for i in range(2, em.n + 1)] + [em.string_flow]
    theta = np.array([em.theta(i) for i in range(2, em.n + 1)])
    q_std[pressures] = est.pressure_process_std_pa
    p_std[pressures] = est.initial_pressure_std_pa
    q_std[flows] = friction.flow_process_std_m3s
    p_std[flows] = est.initial_flow_std_m3s
    q_std[theta] = friction.theta_process_std
    p_std[theta] = friction.theta_initial_std
    for present, index, process_std, initial_std in RANDOM_WALK_PARAMETERS:
        if getattr(em, present):
            q_std[getattr(em, index)] = getattr(est, process_std)
            p_std[getattr(em, index)] = getattr(est, initial_std)

    correlation = friction.theta_correlation + (1.0 - friction.theta_correlation) * np.eye(em.n - 1)
    block = np.ix_(theta, theta)
    covariances = []
    for std in (q_std, p_std):
        M = np.diag((std / scale) ** 2)
        s = std[theta] / scale[theta]
        M[block] = np.outer(s, s) * correlation
        covariances.append(M)

    noise = est.measurement_noise
    sigma = np.array([noise.block_position_m, noise.choke_dp_pa, noise.bhp_pa,
                      noise.string_flow_m3s])
    y_index, _ = measurement_map(em)
    return UkfTuning(
        process=covariances[0], initial=covariances[1],
        measurement=np.diag((sigma / scale[y_index]) ** 2),
        max_std=est.max_std_factor * p_std / scale,
        theta_index=theta, theta_correlation=correlation,
        theta_max=friction.theta_max / scale[theta],
        theta_base_std=q_std[theta] / scale[theta],
        theta_motion_var=(friction.theta_motion_std / scale[theta]) ** 2)
