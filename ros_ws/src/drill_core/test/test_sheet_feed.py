"""The trip sheet fed from the rig's streams: each measurement read with the floor's step
for the frame before it, however the two streams (each in its order) interleave, the same
rows as a sheet fed in order; a measurement whose step never comes is passed over."""
import math
import random

import pytest

from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.sequence import CONNECTION, DONE, MOVING, TripStep
from drill_core.tripping.sheet_feed import TripSheetFeed
from drill_core.tripping.stands import StandVolumes
from drill_core.tripping.trip_sheet import TripSheet
from drill_core.well import build_geometry

FRAME_NS = 100_000_000
BHP_REF_PA, BAND_PA = 6.85e7, 2.0e5


@pytest.fixture(scope="module")
def volumes():
    return StandVolumes.of(build_geometry(load_rig(config_dir()).well), 28.0)


def streams():
    """Two stands: 60 frames moving, 40 in a connection each, then done; the floor's steps
    and the measurements (BHP swabbed 3 bar in every fifth frame, the tank draining)."""
    steps, measurements = [], []
    phases = [(stand, MOVING, False) for stand in (1, 2) for _ in range(60)]
    phases = phases[:60] + [(1, CONNECTION, True)] * 40 + phases[60:] + [(2, CONNECTION, True)] * 40
    phases += [(2, DONE, True)] * 3
    for k, (stand, phase, slips) in enumerate(phases):
        steps.append((k * FRAME_NS, TripStep(phase=phase, stand=stand, slips_set=slips,
                                             latched=not slips, pump_factor=1.0,
                                             bit_height_target_m=0.0, stands_pulled=stand - 1)))
        measurements.append(((k + 1) * FRAME_NS, BHP_REF_PA - (3.0e5 if 20 <= k < 40 else 0.0),
                             6.0 - 0.002 * k))
    return steps, measurements


def in_order(volumes, steps, measurements):
    sheet = TripSheet(TripProgramme(direction="out", stands=2), volumes, BAND_PA)
    for (_, step), (stamp, bhp, tank) in zip(steps, measurements):
        sheet.observe(stamp * 1e-9, step, bhp, BHP_REF_PA, tank)
    return sheet.rows


def fed(volumes, events):
    feed = TripSheetFeed(TripProgramme(direction="out", stands=2), volumes, FRAME_NS)
    feed.reference(BHP_REF_PA, BAND_PA)
    for kind, item in events:
        if kind == "floor":
            feed.floor(*item)
        else:
            feed.measurement(*item)
    return feed


def test_in_order_and_out_of_order_give_the_same_rows(volumes):
    steps, measurements = streams()
    expected = in_order(volumes, steps, measurements)
    assert [r.stand for r in expected] == [1, 2]
    # swabbed 3 bar in frames 20-39: the gauge's 1 s mean (10 frames) is past the 2 bar band
    # while at least 7 of its 10 are swabbed, frames 26 to 42
    assert expected[0].outside_band_s == pytest.approx(17 * 0.1)
    assert expected[0].peak_swab_pa == pytest.approx(3.0e5) and expected[1].peak_swab_pa == 0.0
    ordered = [e for pair in zip((("floor", s) for s in steps),
                                 (("measurement", m) for m in measurements)) for e in pair]
    assert fed(volumes, ordered).sheet.rows == expected
    measurements_first = [("measurement", m) for m in measurements] + [("floor", s) for s in steps]
    assert fed(volumes, measurements_first).sheet.rows == expected
    rng = random.Random(5)                      # each stream in order, interleaved at random
    floors = [("floor", s) for s in steps]
    readings = [("measurement", m) for m in measurements]
    merged = []
    while floors or readings:
        source = floors if floors and (not readings or rng.random() < 0.5) else readings
        merged.append(source.pop(0))
    assert fed(volumes, merged).sheet.rows == expected


def test_a_measurement_whose_step_never_comes_is_passed_over(volumes):
    steps, measurements = streams()
    lost = 30                                   # the floor's step of frame 30 is lost
    events = [e for k, (s, m) in enumerate(zip(steps, measurements))
              for e in ((("floor", s),) if k != lost else ()) + (("measurement", m),)]
    feed = fed(volumes, events)
    kept = [(s, m) for k, (s, m) in enumerate(zip(steps, measurements)) if k != lost]
    sheet = TripSheet(TripProgramme(direction="out", stands=2), volumes, BAND_PA)
    for (_, step), (stamp, bhp, tank) in kept:
        sheet.observe(stamp * 1e-9, step, bhp, BHP_REF_PA, tank)
    assert feed.sheet.rows == sheet.rows
    assert feed.pairs.waiting() == 0            # nothing left waiting on the lost frame
    assert math.isfinite(feed.sheet.rows[0].measured_fill_m3)
