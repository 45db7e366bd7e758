"""FramePairs: a measurement t_k goes out with the floor's step t_k - dt, in stamp order,
whichever stream comes first; the first frame has no step before it, and a step passed
over by a later one will not come."""
import itertools

import pytest

from drill_core.tripping.frame_pairs import FramePairs

DT = 100


def _feed(events):
    pairs, out = FramePairs(DT), []
    for kind, stamp in events:
        out += (pairs.item(stamp, f"m{stamp}") if kind == "m" else pairs.partner(stamp, f"s{stamp}"))
    return out


EXPECTED = [(0, "m0", None), (100, "m100", "s0"), (200, "m200", "s100"), (300, "m300", "s200")]


@pytest.mark.parametrize("order", range(6))
def test_every_interleaving_gives_the_same_pairs_in_stamp_order(order):
    measurements = [("m", k * DT) for k in range(4)]
    steps = [("s", k * DT) for k in range(3)]
    # the two streams each in their own order, merged in one of several ways
    merges = list(itertools.islice(_merges(measurements, steps), 0, None, 5))
    assert _feed(merges[order % len(merges)]) == EXPECTED


def _merges(a, b):
    if not a or not b:
        yield a + b
        return
    for rest in _merges(a[1:], b):
        yield [a[0]] + rest
    for rest in _merges(a, b[1:]):
        yield [b[0]] + rest


def test_a_measurement_waits_for_its_step():
    pairs = FramePairs(DT)
    assert pairs.item(0, "m0") == [(0, "m0", None)]
    assert pairs.item(100, "m100") == []
    assert pairs.item(200, "m200") == []
    assert pairs.waiting() == 2
    assert pairs.partner(0, "s0") == [(100, "m100", "s0")]
    assert pairs.partner(100, "s100") == [(200, "m200", "s100")]


def test_a_step_passed_over_releases_its_measurement_without_one():
    pairs = FramePairs(DT)
    pairs.item(0, "m0")
    assert pairs.item(300, "m300") == []
    assert pairs.partner(200, "s200") == [(300, "m300", "s200")]
    assert pairs.item(200, "m200") == [(200, "m200", None)]     # s100 would have come before s200
