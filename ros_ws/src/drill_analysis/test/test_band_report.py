"""The band time by rig-floor phase from truth samples made up with known excursions."""
import numpy as np

from drill_analysis import band_report as br

NS = 1_000_000_000
REF_PA, BAND_PA = 6.85e7, 2.0e5


def test_each_sample_outside_counts_its_period_under_or_over_in_the_phase_in_force():
    t = np.arange(0.0, 10.0, 0.1)                     # 100 samples, 0.1 s apart
    bhp = np.full_like(t, REF_PA)
    bhp[(t >= 2.0) & (t < 2.5)] = REF_PA - 3.0e5      # 5 samples under, while moving
    bhp[(t >= 6.0) & (t < 6.3)] = REF_PA + 2.5e5      # 3 over, in the ramp-down ...
    bhp[(t >= 7.0) & (t < 7.2)] = REF_PA - 2.1e5      # ... and 2 under after it
    bhp[(t >= 4.0) & (t < 4.5)] = REF_PA + 2.0e5      # on the band's edge: inside
    bhp[:3] = REF_PA - 5.0e5                          # before the floor's first phase
    phases = {1 * NS: "moving", 5 * NS: "pump_down", 8 * NS: "connection"}
    by_phase = br.outside_band_by_phase(t, bhp, REF_PA, BAND_PA, phases)
    assert set(by_phase) == {"moving", "pump_down"}   # nothing outside in the connection
    assert np.isclose(by_phase["moving"][br.UNDER], 0.5) and by_phase["moving"][br.OVER] == 0.0
    assert np.isclose(by_phase["pump_down"][br.OVER], 0.3)
    assert np.isclose(by_phase["pump_down"][br.UNDER], 0.2)


def test_references_per_sample_and_a_phase_published_at_a_samples_stamp():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    ref = np.array([REF_PA, REF_PA, REF_PA + 1.0e6, REF_PA + 1.0e6])   # the reference moved
    bhp = np.full(4, REF_PA + 0.5e6)          # over, over, under, under the moving reference
    phases = {0: "set_slips", 2 * NS: "pump_down"}    # pump_down in force from t = 2 s on
    by_phase = br.outside_band_by_phase(t, bhp, ref, BAND_PA, phases)
    assert by_phase == {"set_slips": {br.UNDER: 0.0, br.OVER: 2.0},
                        "pump_down": {br.UNDER: 2.0, br.OVER: 0.0}}
    lines = br.format_rows(by_phase)
    assert [line.split()[0] for line in lines[1:]] == ["set_slips", "pump_down"]  # floor order
    assert "0.0 /    2.0" in lines[1] and "2.0 /    0.0" in lines[2]


def test_no_floor_or_a_single_sample_gives_no_figures():
    t = np.arange(0.0, 1.0, 0.1)
    assert br.outside_band_by_phase(t, np.zeros_like(t), REF_PA, BAND_PA, {}) == {}
    assert br.outside_band_by_phase([0.0], [0.0], REF_PA, BAND_PA, {0: "moving"}) == {}
