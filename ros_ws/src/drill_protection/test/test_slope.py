"""The running least-squares slope (drill_protection.slope) against numpy's fit of the
same samples, as samples come in at the end and the ones older than a window go out at
the start."""
import math

import numpy as np
import pytest

from drill_protection.slope import LeastSquaresSlope


def test_the_running_slope_is_the_least_squares_fit_of_the_samples_kept():
    rng = np.random.default_rng(3)
    t = np.arange(60) * 0.1
    v = 0.02 * t + rng.normal(0.0, 0.01, t.size)
    s = LeastSquaresSlope()
    for k in range(t.size):
        s.append(t[k], v[k])
        s.drop_before(t[k] - 2.95)                # the last 30 samples
        assert len(s) == min(k + 1, 30)
        if k >= 2:
            kept = slice(max(k - 29, 0), k + 1)
            assert s.slope == pytest.approx(np.polyfit(t[kept], v[kept], 1)[0], rel=1e-9)


def test_under_three_samples_or_no_spread_in_time_there_is_no_slope():
    s = LeastSquaresSlope()
    s.append(0.0, 1.0)
    s.append(1.0, 2.0)
    assert math.isnan(s.slope)
    s.clear()
    for _ in range(3):
        s.append(5.0, 1.0)
    assert math.isnan(s.slope)
