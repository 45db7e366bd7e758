"""The trip tank's mass balance: the level is the volume over the area, and the volume is
the start plus what came back less what was drawn; an empty tank gives nothing more."""

import numpy as np
import pytest

from drill_core.tripping.trip_tank import TripTank


def test_the_tank_keeps_the_balance_of_returns_and_draws():
    rng = np.random.default_rng(7)
    tank = TripTank(area_m2=1.5, volume_m3=4.0)
    returned, drawn = rng.uniform(0.0, 0.02, 500), rng.uniform(0.0, 0.02, 500)
    for q_in, q_out in zip(returned, drawn):
        tank = tank.step(q_in, q_out, 0.1)
    expected = 4.0 + 0.1 * (returned.sum() - drawn.sum())
    assert tank.volume_m3 == pytest.approx(expected, rel=1e-12)
    assert tank.level_m == pytest.approx(expected / 1.5, rel=1e-12)
    assert tank.shortfall_m3 == 0.0


def test_an_empty_tank_counts_what_it_could_not_give():
    tank = TripTank(area_m2=1.0, volume_m3=0.05).step(0.0, 0.01, 10.0)
    assert tank.volume_m3 == 0.0 and tank.shortfall_m3 == pytest.approx(0.05)
    tank = tank.step(0.0, 0.01, 1.0)
    assert tank.shortfall_m3 == pytest.approx(0.06)
