"""The gauge window: the samples of the last span, their median and mean, a dropout left
out while time passes, and the two coverage rules (a whole span since the samples began;
the oldest sample a share of a span old)."""
import math

from drill_core.recent_samples import RecentSamples


def test_the_window_holds_the_last_span_of_samples():
    window = RecentSamples(1.0)
    for k, value in enumerate([5.0, 1.0, 2.0, 3.0, 100.0]):
        window.add(0.25 * k, value)                       # 0, 0.25, ..., 1.0 s
    # the sample stamped 0 is a whole span old at 1.0 s: out; median and mean of the rest
    assert window.median == 2.5
    assert window.mean == (1.0 + 2.0 + 3.0 + 100.0) / 4


def test_a_dropout_is_left_out_and_time_passes():
    window = RecentSamples(1.0)
    window.add(0.0, 4.0)
    window.add(0.5, math.nan)
    assert window.mean == 4.0 and window.spans(0.5, 0.5)
    window.add(1.0, math.inf)                             # the only sample leaves the window
    assert not window and math.isnan(window.median) and math.isnan(window.mean)
    assert not window.spans(1.0, 0.0)


def test_full_needs_a_whole_span_without_a_gap():
    window = RecentSamples(1.0)
    for k in range(10):
        window.add(0.1 * k, 1.0)
    assert not window.full(0.9)
    window.add(1.0, 1.0)
    assert window.full(1.0)
    for k in range(11, 22):                               # 1.1 s of dropout: samples gone
        window.add(0.1 * k, math.nan)
    window.add(2.2, 1.0)
    assert window and not window.full(2.2)                # the span counts from 2.2 s again
    assert not window.spans(2.2, 0.5) and window.spans(2.2, 0.0)
