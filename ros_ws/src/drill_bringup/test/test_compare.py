"""The comparison table: SI summaries shown in bar, ratios against the baseline."""
import numpy as np

from drill_bringup import compare, report


def _summary(bhp_rmse_bar, outside_s, surge_bar, swab_bar, solves=0):
    s = {"block_position_mean_error_m": -1.5, "block_position_rmse_m": 11.0,
         "bhp_mean_error_pa": -0.2e5, "bhp_rmse_pa": bhp_rmse_bar * 1e5,
         "bhp_window_violations": 3, "bhp_worst_excursion_pa": 1.5e5,
         "bhp_time_outside_s": outside_s, "peak_surge_pa": surge_bar * 1e5,
         "peak_swab_pa": swab_bar * 1e5, "max_string_speed_mps": 0.5,
         "bhp_estimate_rmse_pa": 0.5e5, "trip_legs": [[28.0, 61.0], [0.0, None]]}
    if solves:
        s.update(solve_time_median_s=0.015, solve_time_max_s=0.030, solves=solves, fallbacks=1)
    return s


def test_table_has_paper_figures_and_baseline_ratios():
    results = {
        "case2": {"summary": _summary(0.8, 40.0, 3.0, -4.0, solves=600), "run_dir": "/r/c2",
                  "wall_s": 50.0},
        "baseline": {"summary": _summary(1.6, 100.0, 9.0, -10.0), "run_dir": "/r/b", "wall_s": 45.0},
    }
    text = compare.markdown(results)
    assert "| case2 | nmpc | -1.500 \\| -0.004 | -0.200 \\| -0.005 | 11.000 \\| 11.377 | " \
           "0.800 \\| 0.464 |" in text
    assert "| baseline | baseline | -1.500 \\| n/a |" in text
    assert "| case2 | 0.50 x | 40 s vs 100 s | 3.0 vs 9.0 bar | -4.0 vs -10.0 bar |" in text
    legs = "to 28.0 m in 61 s, to 0.0 m not reached"
    assert f"| case2 | 40.0 | 1.50 | 3 | 3.00 | -4.00 | 0.500 | {legs} | 0.500 | 15.0 / 30.0 | 1 | 50.0 |" \
        in text
    assert f"| baseline | 100.0 | 1.50 | 3 | 9.00 | -10.00 | 0.500 | {legs} | 0.500 | n/a | 0 | 45.0 |" \
        in text


def test_trip_legs_time_each_target_until_arrival():
    t = np.arange(0.0, 100.0, 1.0)
    target = np.where(t < 10.0, 0.0, np.where(t < 60.0, 28.0, 0.0))
    pos = np.clip(t - 12.0, 0.0, 28.0)                         # 1 m/s from t = 12 s: 28 m at 40 s
    pos[t >= 60.0] = 28.0 - (t[t >= 60.0] - 60.0) * 0.5        # back down, 0.5 m only at 115 s
    assert report.trip_legs(t, pos, target) == [(28.0, 30.0), (0.0, None)]
    assert report.trip_legs(t, pos, np.zeros_like(t)) == []    # already on target: no leg

