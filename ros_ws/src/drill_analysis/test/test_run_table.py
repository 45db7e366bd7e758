"""The printed run summary: a multi-stand trip's leaves out the block's distance, position
error and legs (the string's position counts from a new top after each connection), and a
single trip's keeps them; a realtime run's frame lateness gives the frames skipped only
where the run counted them."""
from drill_analysis.report import format_table

SUMMARY = {"duration_s": 600.0, "trip_distance_m": 28.5, "max_string_speed_mps": 0.51,
           "block_position_mean_error_m": 19.5, "block_position_rmse_m": 22.8,
           "bhp_mean_error_pa": -0.2e5, "bhp_rmse_pa": 0.6e5, "bhp_rmse_settled_pa": 0.6e5,
           "bhp_window_violations": 3, "bhp_worst_excursion_pa": 0.5e5,
           "bhp_time_outside_s": 12.0, "bhp_time_outside_settled_s": 12.0,
           "trip_legs": [[28.0, 60.0]], "trip_overshoot_m": 0.1,
           "peak_surge_pa": 3e5, "peak_swab_pa": -4e5}


def test_a_multi_stand_table_leaves_out_the_block_frames_figures():
    single = format_table("trip", SUMMARY)
    multi = format_table("trip_out", SUMMARY, multi_stand=True)
    for text in ("block position [m]", "trip legs", "trip distance"):
        assert text in single and text not in multi
    assert "max 0.51 m/s (each stand's move: the trip sheet below)" in multi
    assert "BHP [bar]" in multi and "0.600" in multi


def test_a_realtime_run_gives_the_frames_skipped_it_counted_and_an_older_run_none():
    late = {"frame_late_p99_s": 0.002, "frame_late_max_s": 0.41}
    counted = format_table("short_trip", SUMMARY | late | {"frames_skipped": 4.0})
    older = format_table("short_trip", SUMMARY | late)
    assert "p99 2.0 ms, max 410.0 ms, 4 frames skipped" in counted
    assert "p99 2.0 ms, max 410.0 ms (plant frames" in older and "skipped" not in older
