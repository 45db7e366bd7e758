"""The in-process closed loop (drill_studies.loop_bench) that the ladder of docs/nmpc.md
stands on: the truth plant, the actuator models, a state source and a controller (and the
scenario's events and the process protection)."""

import numpy as np
import pytest

from drill_studies import loop_bench
from drill_core.rig_root import rig_root


@pytest.mark.slow
def test_automated_mpd_holds_the_short_trip_in_band_from_the_true_state():
    r = loop_bench.run("short_trip", "automated_mpd", "truth")
    assert r["trip_legs"][0][1] is not None                     # the 8 m leg completed
    assert r["bhp_worst_excursion_pa"] < 1.0e5 and r["bhp_rmse_pa"] < 1.0e5
    assert r["bhp_estimate_rmse_pa"] == 0.0                     # the oracle reads the truth


@pytest.mark.slow
def test_nmpc_on_the_ukf_state_trips_and_holds_bhp():
    r = loop_bench.run("short_trip", "nmpc", "ukf")
    trace = r["trace"]
    assert np.max(trace["string_position_m"]) > 7.5                           # pulled the 8 m
    assert r["bhp_rmse_pa"] < 1.0e5 and r["fallbacks"] == 0
    assert 0.0 < r["bhp_estimate_rmse_pa"] < 0.5e5              # a real estimate, not the truth
    # the choke worked the trip: its opening moved with the surge and swab
    assert np.max(trace["choke_opening_1"]) - np.min(trace["choke_opening_1"]) > 0.02


@pytest.mark.slow
def test_a_pump_trip_in_process_meets_the_protections_answer():
    """The scenario's events act (the mud pump trips on its actuator) and the process
    protection is in the loop: it finds the lost circulation and BHP stays in the window."""
    scenario = rig_root() / "test" / "scenarios" / "pump_trip_short.yaml"
    r = loop_bench.run(str(scenario), "nmpc", "ukf", protection=True)
    trace = r["trace"]
    assert [t for t, text in r["alarms"]] == [pytest.approx(8.1)]
    assert trace["spp_pa"][-1] < 1.0e5 and trace["bpp_flow_m3s"][-1] > 0.005      # pump off, bpp on
    assert r["bhp_under_pore_s"] == 0.0 and r["bhp_over_fracture_s"] == 0.0
