"""Frozen channels and staleness before the UKF."""
import math

import numpy as np

from drill_core.channel_watch import ChannelWatch


def test_a_repeated_value_is_frozen_after_n_samples_and_released_when_it_moves():
    watch = ChannelWatch(("a", "b"), frozen_after=3)
    rng = np.random.default_rng(0)
    out = []
    for k in range(30):
        out.append(watch.screen(0.1 * k, [5.0 if 10 <= k < 20 else rng.normal(), rng.normal()]))
        if k == 19:
            assert abs(watch.oldest_age_s(1.9) - 0.8) < 1e-12     # "a" last usable at k = 11
    frozen_at = [k for k, (_, names) in enumerate(out) if "a" in names]
    assert frozen_at == list(range(12, 20))               # 3rd repeat on: 8 samples left out
    assert all(math.isnan(out[k][0][0]) for k in frozen_at)
    assert all(math.isfinite(y[1]) and "b" not in names for y, names in out)
    assert watch.frozen_samples == 8 and abs(watch.oldest_age_s(0.1 * 29)) < 1e-12


def test_a_dropout_ages_its_channel_and_nan_never_counts_as_frozen():
    watch = ChannelWatch(("bhp",), frozen_after=2)
    watch.screen(0.0, [1.0])
    for k in range(1, 11):
        y, names = watch.screen(0.1 * k, [math.nan])
        assert names == () and math.isnan(y[0])
    assert watch.oldest_age_s(1.0) == 1.0 and watch.frozen_samples == 0


def test_zero_never_freezes_a_channel():
    watch = ChannelWatch(("a",), frozen_after=0)
    assert all(watch.screen(0.1 * k, [1.0])[1] == () for k in range(20))
