"""The kick detector's learnt flow baseline (plain Python; docs/mismatch.md).

The flow balance takes out the mud that pressure changes compress with the model's
compliances V_i / beta; the mud report's bulk modulus and a washed-out hole are off. So the
windowed excess flow of a well that takes and gives nothing is not zero while the
pressures move but

    e = c_top dp_top/dt + c_bottom dp_bottom/dt

(c the compliances' errors, the pressure rates over the detector's window).
:class:`FlowBaseline` fits (c_top, c_bottom) by recursive least squares with exponential
forgetting over ``time_constant_s``, learning only from samples the detector reads as
quiet (no alarm raised or pending, the corrected excess within half the threshold), each
term bounded at WEIGHT_LIMIT prior standard deviations; the detector judges e less the
fit. Successive windowed excesses share their window (``correlation_s``): each sample
counts as dt / correlation_s of an independent reading. It learns no constant term: a
loss or an influx that is there when the balance starts would look like a meter's offset
and be learnt away (a weak zone met 10 s into a trip was, in a first version); a meter
that reads off shows as an alarm, which is what the crew must see. What it can take for
compressibility is a formation flow that follows the pressure's rate over the forgetting
time.
"""
from __future__ import annotations

import math

import numpy as np

# Prior of the fit: its standard deviation per term (compliance errors m^3/Pa, about 20 %
# of the reference well's) before any sample; small enough that a few noisy samples do
# not swing it.
PRIOR_STD = np.array([5.0e-9, 5.0e-9])
# The fit never corrects a compliance by more than this many prior standard deviations
# (about 40 % of the reference well's each): a slow influx that raises the pressures of a
# nearly closed well looks like compressibility, and must not be learnt away without end.
WEIGHT_LIMIT = 2.0


class FlowBaseline:
    """Recursive least squares of the quiet excess flow on [dp_top/dt, dp_bottom/dt]."""

    def __init__(self, time_constant_s: float, noise_m3s: float, correlation_s: float):
        self.time_constant_s = time_constant_s
        self.noise_var = noise_m3s ** 2
        self.correlation_s = correlation_s
        self.weights = np.zeros(2)
        self.covariance = np.diag(PRIOR_STD ** 2)

    @staticmethod
    def regressors(choke_dp_rate_pa_s: float, bhp_rate_pa_s: float) -> np.ndarray:
        return np.array([choke_dp_rate_pa_s, bhp_rate_pa_s])

    def baseline_m3s(self, phi: np.ndarray) -> float:
        """The learnt excess flow of a quiet well at these regressors [m^3/s]."""
        return float(self.weights @ phi)

    def learn(self, phi: np.ndarray, excess_m3s: float, dt_s: float) -> None:
        """One quiet sample: its raw excess flow ``excess_m3s`` at regressors ``phi``."""
        if not (math.isfinite(excess_m3s) and np.all(np.isfinite(phi))):
            return
        keep = math.exp(-dt_s / self.time_constant_s)
        P = self.covariance / keep
        # samples of one window share its error: each tells dt / correlation_s of an
        # independent one
        noise_var = self.noise_var * max(1.0, self.correlation_s / dt_s)
        gain = P @ phi / (noise_var + phi @ P @ phi)
        self.weights = np.clip(self.weights + gain * (excess_m3s - self.weights @ phi),
                               -WEIGHT_LIMIT * PRIOR_STD, WEIGHT_LIMIT * PRIOR_STD)
        P = P - np.outer(gain, phi @ P)
        # forgetting never widens a term past its prior (a direction the data do not excite)
        shrink = np.sqrt(np.minimum(1.0, PRIOR_STD ** 2 / np.maximum(np.diag(P), 1e-300)))
        self.covariance = P * np.outer(shrink, shrink)
