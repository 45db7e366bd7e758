"""The trip sheet's BHP figures judge the gauge's 1 s mean: a well held inside its band
books no time outside it and no peak from the gauge's noise, a swab that lasts is booked
whole, and a gauge dropout is left out of the mean."""
import math

import numpy as np
import pytest

from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.sequence import DONE, MOVING, TripStep
from drill_core.tripping.stands import StandVolumes
from drill_core.tripping.trip_sheet import StandRow, TripSheet

FRAME_S = 0.1
BHP_REF_PA, BAND_PA = 6.85e7, 2.0e5
GAUGE_NOISE_PA = 1.0e5          # config/plant.yaml: the BHP gauge's sigma
VOLUMES = StandVolumes(steel_m3=0.1, closed_end_m3=0.36, contents_m3=0.26)


def one_stand(deviations_pa) -> StandRow:
    """The sheet's row of one stand moving for as many frames as ``deviations_pa`` (the
    gauge's BHP less its reference, Pa), then done."""
    sheet = TripSheet(TripProgramme(direction="out", stands=1), VOLUMES, BAND_PA)
    moving = TripStep(phase=MOVING, stand=1, slips_set=False, latched=True, pump_factor=1.0,
                      bit_height_target_m=0.0, stands_pulled=0)
    for k, deviation in enumerate(deviations_pa):
        sheet.observe(k * FRAME_S, moving, BHP_REF_PA + deviation, BHP_REF_PA, 6.0)
    sheet.observe(len(deviations_pa) * FRAME_S, TripStep(
        phase=DONE, stand=1, slips_set=True, latched=False, pump_factor=1.0,
        bit_height_target_m=0.0, stands_pulled=1), BHP_REF_PA, BHP_REF_PA, 6.0)
    [row] = sheet.rows
    return row


def test_the_gauges_noise_books_nothing_outside_the_band():
    noise = np.random.default_rng(3).normal(0.0, GAUGE_NOISE_PA, 2400)    # a 240 s stand
    # sample by sample 4.6 % of the frames are past 2 sigma: about 11 s outside the band
    assert np.sum(np.abs(noise) > BAND_PA) * FRAME_S > 8.0
    row = one_stand(noise)
    assert row.outside_band_s == 0.0
    # the mean of 10 samples has a sigma of 0.32 bar: its largest of 2400 under 4.5 sigma
    assert max(row.peak_surge_pa, row.peak_swab_pa) < 4.5 * GAUGE_NOISE_PA / math.sqrt(10)


def test_a_swab_that_lasts_is_booked_whole_through_the_noise():
    noise = np.random.default_rng(4).normal(0.0, GAUGE_NOISE_PA, 1200)
    swab = np.where((np.arange(1200) >= 300) & (np.arange(1200) < 600), -4.0e5, 0.0)  # 30 s
    row = one_stand(swab + noise)
    assert row.outside_band_s == pytest.approx(30.0, abs=1.0)
    assert row.peak_swab_pa == pytest.approx(4.0e5, abs=1.5e5)
    assert row.peak_surge_pa < 2.0e5


def test_a_gauge_dropout_is_left_out_of_the_mean():
    # 2 s of dropout, then 2 s of -3 bar: nothing is judged until the samples span half
    # the 1 s window (t = 2.5 s), then 15 frames are booked
    row = one_stand([math.nan] * 20 + [-3.0e5] * 20)
    assert row.peak_swab_pa == pytest.approx(3.0e5)
    assert row.outside_band_s == pytest.approx(1.5)
    # a 0.5 s dropout inside a 4.5 s swab at -3 bar, 0 around it; the window holds the last
    # 10 frames: the mean passes -2 bar on the swab's 7th frame and holds the swab's samples
    # through the dropout; on the 5th frame after it the samples held span 0.4 s, less than
    # half the window, and that frame is not judged; back inside 3 frames after the swab:
    # 4.5 - 0.6 - 0.1 + 0.3 s
    swab = [-3.0e5] * 20 + [math.nan] * 5 + [-3.0e5] * 20
    row = one_stand([0.0] * 20 + swab + [0.0] * 20)
    assert row.peak_swab_pa == pytest.approx(3.0e5)
    assert row.outside_band_s == pytest.approx(4.1)
