"""The protection's reading of a measurement (drill_protection.reading): a gauge repeating
its value is read as a dropout from the sample that makes it frozen until it moves again,
announced once each way; the other gauges and the string-flow meter are read as they are."""
import math
from types import SimpleNamespace

from drill_protection.reading import SCREENED, ReadingScreen

FROZEN_AFTER = 3


def measurement(k: int, bhp_pa: float | None = None):
    """A live sample k (every gauge's value moves with k), the BHP gauge at ``bhp_pa``."""
    values = {name: 1.0 + 0.01 * k + i for i, name in enumerate(SCREENED)}
    if bhp_pa is not None:
        values["bhp_pa"] = bhp_pa
    return SimpleNamespace(**values, string_flow_m3s=0.0166, string_flow_valid=True,
                           trip_tank_volume_m3=6.0)


def test_a_frozen_gauge_reads_as_a_dropout_until_it_moves_again():
    screen = ReadingScreen(FROZEN_AFTER)
    codes = []
    for k in range(10):
        m = measurement(k, bhp_pa=6.8e7 if 2 <= k < 8 else None)   # frozen from k = 2 to 7
        codes += [(k, n.code) for n in screen.observe(0.1 * k, m)]
        r = screen.of(m)
        frozen = 2 + FROZEN_AFTER - 1 <= k < 8          # the third repeat of 6.8e7 on
        assert math.isnan(r.bhp_pa) == frozen
        assert r.choke_dp_pa == m.choke_dp_pa and r.return_flow_m3s == m.return_flow_m3s
        assert r.string_flow_m3s == 0.0166 and r.string_flow_valid
    assert codes == [(4, "gauge_frozen"), (8, "gauge_live")]


def test_nothing_is_screened_when_the_count_is_zero():
    screen = ReadingScreen(0)
    for k in range(10):
        m = measurement(k, bhp_pa=6.8e7)
        assert screen.observe(0.1 * k, m) == []
        assert screen.of(m).bhp_pa == 6.8e7
