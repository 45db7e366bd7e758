"""Two stands pulled out of the truth plant on the in-process trip bench
(drill_studies.trip_bench): the rig floor on its own instruments drives the drawworks (its
string loop while moving, its encoder in the slips) and the mud pump through each
connection, the plant slips, racks and fills from the trip tank, the trip sheet keeps the
fill, and the estimator follows what the floor does. The choke is held at its opening:
nothing here holds the BHP (the controllers do, in the graph)."""

import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.sequence import ARRIVAL_TOLERANCE_M
from drill_core.tripping.trip_sheet import stands_per_hour
from drill_studies.trip_bench import run_trip

pytestmark = pytest.mark.slow          # closed-loop trips in process, seconds each

STAND_M = 28.0
TRIP_SPEED_MPS = 0.5
BAR = 1.0e5


def _trip(floor_aware=True, stands=2, settle_s=90.0, controller="held_choke"):
    return run_trip(load_rig(config_dir()), [TripProgramme(direction="out", stands=stands,
                                                           stand_length_m=STAND_M)],
                    seed=12, trip_speed_mps=TRIP_SPEED_MPS, settle_s=settle_s,
                    floor_aware=floor_aware, controller=controller)


@pytest.fixture(scope="module")
def one_stand_unaware():
    """One stand at the held choke, the estimator not told what the floor does."""
    return _trip(floor_aware=False, stands=1, settle_s=0.0)


@pytest.fixture(scope="module")
def trip():
    return _trip()


def test_two_stands_come_out_and_the_string_is_two_stands_shorter(trip):
    assert trip.floor.stands_pulled == 2
    assert trip.sim.wm.geometry.bit_above_bhp_node_m == 2 * STAND_M
    assert trip.log["bit_height_m"][-1] == pytest.approx(2 * STAND_M, abs=ARRIVAL_TOLERANCE_M)
    assert [row.stand for row in trip.sheets[0].rows] == [1, 2]


def test_the_string_never_drops_and_the_line_never_jumps(trip):
    assert trip.log["string_velocity_mps"].min() > -0.05                   # [m/s]
    # a frame's change of pull: the block's rate limit over the string's stiffness, 0.6 m/s
    # * 0.1 s * 563 kN/m = 34 kN, is the most the drawworks can give
    assert np.abs(np.diff(trip.log["line_tension_n"])).max() < 40.0e3


def test_a_connection_at_a_held_choke_lets_the_well_flow_and_the_trip_sheet_books_it(trip):
    """With the choke held (no back-pressure for the lost friction: the conventional
    connection) each pump stop takes BHP about 29 bar down, under the 660 bar pore
    pressure, and the formation flows. Settled after the trip, the trip tank has given the
    steel of two stands less what the formation gave; the trip sheet's rows (slips to
    slips, each ending 30 s into the pump's restart, the well still refilling its
    compression) book a gain of the influx's size."""
    sheet, truth = trip.sheets[0], trip.sim.truth()
    steel = sheet.volumes.steel_m3
    assert [row.expected_fill_m3 for row in sheet.rows] == pytest.approx([steel, steel])
    assert truth.influx_volume_m3 > 0.05 and truth.loss_volume_m3 == 0.0
    assert trip.drawn_m3 == pytest.approx(2 * steel - truth.influx_volume_m3, abs=0.015)
    assert all(row.gain_m3 > 0.0 for row in sheet.rows)
    assert sheet.cumulative_gain_m3 == pytest.approx(truth.influx_volume_m3, abs=0.05)
    # a stand: the move (56 s at 0.5 m/s, braking) and 150 s of ramps and connection
    assert 10.0 < stands_per_hour(sheet.rows) < 3600.0 / (STAND_M / TRIP_SPEED_MPS + 150.0)
    assert all(row.out_of_slips_s > STAND_M / TRIP_SPEED_MPS for row in sheet.rows)


def test_the_band_time_by_phase_adds_up_to_the_trips_and_is_under_the_band_at_rest(trip):
    """The trip's seconds outside the band, split by the floor's phase (the run report's
    function, drill_analysis.band_report): at the held choke the BHP is under the band
    through each connection's 90 s, the pump stopped."""
    from drill_analysis.band_report import OVER, UNDER
    from drill_core.tripping.sequence import CONNECTION
    from drill_studies.trip_bench import band_figures, trip_figures
    by_phase = band_figures(trip)
    total_s = sum(cell[UNDER] + cell[OVER] for cell in by_phase.values())
    assert total_s == pytest.approx(trip_figures(trip, 6.6e7)["outside_band_s"], abs=1e-6)
    assert by_phase[CONNECTION][UNDER] > 2 * 80.0 and by_phase[CONNECTION][OVER] == 0.0


def test_the_estimator_follows_the_floor_and_is_lost_without_it(trip, one_stand_unaware):
    """Told that the slips hold the string (a virtual block holds the model's string on the
    line) and at each connection that the string is a stand shorter (the new string's
    model, the position counted from its top), the UKF's BHP follows the truth through
    the trip: 0.20 bar RMS on the moves, 0.92 bar RMS and 3.3 bar at worst over the trip
    (seed 12). The model has no influx, so the connections' inflow is what costs it most.
    Not told, its model follows the block down a stand while the string stays in the
    slips, and the estimate is hundreds of bar off by the first connection."""
    def error_bar(run):
        known = np.isfinite(run.log["bhp_estimate_pa"])
        return (run.log["bhp_estimate_pa"] - run.log["bhp_pa"])[known] / BAR, \
            run.log["moving"][known]
    aware, moving = error_bar(trip)
    assert np.sqrt(np.mean(aware[moving] ** 2)) < 0.3
    assert np.sqrt(np.mean(aware ** 2)) < 1.5 and np.abs(aware).max() < 4.0
    naive, _ = error_bar(one_stand_unaware)
    assert np.abs(naive).max() > 100.0


def test_a_stand_out_and_back_in_leaves_the_tank_short_of_only_the_influx():
    """Out one stand, then in again (the floor makes it up, picks the string up off the
    slips, runs it down and sets the slips): the bit is back at the BHP node (within the
    move's arrival tolerance and the string's settling), the string its full length, the
    run-in's row expects the stand's steel back, and settled, the trip tank holds what it
    held at the start plus the formation's influx (the two held-choke connections' 171 L),
    within 10 L."""
    run = run_trip(load_rig(config_dir()),
                   [TripProgramme(direction="out", stands=1, stand_length_m=STAND_M),
                    TripProgramme(direction="in", stands=1, stand_length_m=STAND_M)],
                   seed=12, trip_speed_mps=TRIP_SPEED_MPS, settle_s=90.0)
    out, back = run.sheets
    steel = out.volumes.steel_m3
    assert [len(out.rows), len(back.rows)] == [1, 1] and run.floor.stands_pulled == 0
    assert run.sim.wm.geometry.bit_above_bhp_node_m == 0.0
    assert abs(run.log["bit_height_m"][-1]) < ARRIVAL_TOLERANCE_M
    assert back.rows[0].expected_fill_m3 == pytest.approx(-steel)
    influx = run.sim.truth().influx_volume_m3
    assert influx > 0.05 and run.drawn_m3 == pytest.approx(-influx, abs=0.01)
    assert run.log["string_velocity_mps"].min() > -0.6                     # no fall
    assert np.abs(np.diff(run.log["line_tension_n"])).max() < 40.0e3


def test_the_pi_baselines_choke_traps_some_pressure_through_a_connection(one_stand_unaware):
    """The PI baseline's choke on the measured BHP closes as the pump winds down and traps
    part of the lost friction: the formation gives a fraction of what it gives at the held
    choke and BHP stays higher. (With the back-pressure pump idle it cannot hold the band:
    no flow crosses the choke once the pump stops; seed 12, one stand: BHP at worst about
    26 bar under the reference against 28 at the held choke.)"""
    held = one_stand_unaware
    pi = _trip(stands=1, settle_s=0.0, controller="baseline")
    assert pi.floor.stands_pulled == 1
    assert pi.sim.truth().influx_volume_m3 < 0.5 * held.sim.truth().influx_volume_m3
    assert pi.log["bhp_pa"].min() > held.log["bhp_pa"].min()


def test_the_command_prints_the_trip_sheet_and_the_figures(capsys):
    from drill_studies.trip_bench import main
    assert main(["--stands", "1", "--connection-s", "30", "--settle-s", "10"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("| trip | stand | slips to slips [s]")
    assert out[2].startswith("| out | 1 | ") and out[3] == ""
    assert out[4].startswith("stands per hour ") and "L drawn (10 s after)" in out[4]
    assert out[5].startswith("  BHP outside the band by rig-floor phase, under / over [s]")


def test_automated_mpds_pressure_loop_keeps_the_connection_over_the_pore_pressure():
    """Automated MPD's choke-dp set-point for no flow closes its choke early enough to trap
    the pressure over the 660 bar pore pressure: nothing flows in (seed 12, one stand: BHP
    at worst 664.6 bar, about 20 bar under the reference, the back-pressure pump idle)."""
    mpd = _trip(stands=1, settle_s=0.0, controller="automated_mpd")
    assert mpd.floor.stands_pulled == 1
    assert mpd.sim.truth().influx_volume_m3 < 0.005
    assert mpd.log["bhp_pa"].min() > load_rig(config_dir()).well.formation.pore_pressure_pa


def test_a_mismatch_is_given_to_the_plant_only():
    """``plant_config`` builds the plant (and its actuators); the estimator and the
    controller keep the model. A mud 1 % heavier than reported starts the bench's well
    (circulating, the same choke dp) about 1 % of the hydrostatic head higher at the
    bottom: 0.01 rho g D, the string's friction aside."""
    from drill_core.mismatch import Mismatch, truth_config
    model = load_rig(config_dir())
    heavier = truth_config(model, Mismatch(density_factor=1.01))
    programme = [TripProgramme(direction="out", stands=1, stand_length_m=STAND_M)]
    own = run_trip(model, programme, seed=12, settle_s=0.0, max_s=1.0)
    other = run_trip(model, programme, seed=12, settle_s=0.0, max_s=1.0, plant_config=heavier)
    assert other.sim.config is heavier and own.sim.config is model
    mud = model.well.mud
    depth_m = sum(model.well.segment_lengths_m)                  # a vertical well
    head_pa = 0.01 * mud.density_kgm3 * model.well.gravity_mps2 * depth_m
    rise_pa = other.log["bhp_pa"][0] - own.log["bhp_pa"][0]
    assert rise_pa == pytest.approx(head_pa, rel=0.15)
    with pytest.raises(ValueError, match="state 'oracle' is not one of ukf, truth"):
        run_trip(model, programme, seed=12, state="oracle")


def test_the_mud_pump_is_commanded_the_models_pressure_on_another_mud():
    """As in the graph, the advisors' stand-pipe pressure is the model's operating point's
    (drill_nmpc.advisor_ticks.StartInputs), not the plant's: on a thicker mud than reported
    the pump starts at the plant's own steady-state pressure and lags (5 s) to the model's,
    so the mud circulates less than the 1000 L/min the model's pressure gives the report."""
    from drill_core.hydraulics import rig_well_model
    from drill_core.mismatch import Mismatch, truth_config
    from drill_plant.plant_model import steady_state
    from drill_studies.trip_bench import CHOKE_DP_PA, CIRCULATION_M3S
    model = load_rig(config_dir())
    thicker = truth_config(model, Mismatch(yield_stress_factor=1.3, consistency_factor=1.3))

    def spp_pa(config):       # the bench's start: its circulation at its choke dp
        return steady_state(rig_well_model(config), CIRCULATION_M3S, CHOKE_DP_PA, 0.0).inputs[3]

    programme = [TripProgramme(direction="out", stands=1, stand_length_m=STAND_M)]
    run = run_trip(model, programme, seed=12, settle_s=0.0, max_s=25.0, plant_config=thicker)
    model_pa, plant_pa = spp_pa(model), spp_pa(thicker)
    assert plant_pa > model_pa + 5.0e5                      # the thicker mud needs more
    assert run.log["time_s"][-1] > 20.0                     # four of the pump's lags
    assert abs(run.sim.inputs[3] - model_pa) < 0.05 * (plant_pa - model_pa)


@pytest.fixture(scope="module")
def tight_choke_nmpc():
    """One stand under the NMPC, the plant's choke passing 8 % less than its data sheet."""
    from drill_core.mismatch import Mismatch, truth_config
    model = load_rig(config_dir())
    tight = truth_config(model, Mismatch(choke_coefficient_factor=0.92))
    return run_trip(model, [TripProgramme(direction="out", stands=1, stand_length_m=STAND_M)],
                    seed=31, settle_s=0.0, max_s=250.0, controller="nmpc", plant_config=tight)


def test_through_a_connection_the_estimate_holds_on_a_choke_tighter_than_its_data_sheet(
        tight_choke_nmpc):
    """The NMPC runs the back-pressure pump through the choke while the mud pump stands
    for the connection; the plant's choke passes 8 % less than the data sheet says. The
    valve law calibrated on the return-flow meter keeps the BHP estimate at rest within
    0.21 bar RMS of the truth (seed 31, one stand); the law uncalibrated let it drift to
    2.09 bar RMS (docs/experiments/2026-12-06-multi-stand-mismatch-bench.md)."""
    run = tight_choke_nmpc
    assert run.floor.stands_pulled == 1
    known = np.isfinite(run.log["bhp_estimate_pa"])
    at_rest = known & ~run.log["moving"]
    error_bar = (run.log["bhp_estimate_pa"] - run.log["bhp_pa"])[at_rest] / BAR
    assert np.sqrt(np.mean(error_bar ** 2)) < 0.5


def test_the_nmpcs_prediction_errors_are_grouped_by_the_floors_phase(tight_choke_nmpc):
    """Every solve whose horizon the run reaches is judged against the truth plant's BHP, in
    the run's group and its phase's (the report's function, drill_analysis.prediction_report);
    one second ahead the model's and the estimate's error is a bar or so, not tens."""
    from drill_core.tripping.sequence import CONNECTION, MOVING, PUMP_DOWN
    from drill_ros.stamps import seconds_to_ns
    from drill_studies.trip_bench import prediction_figures
    run = tight_choke_nmpc
    errors = prediction_figures(run)
    end_ns = seconds_to_ns(run.log["time_s"][-1])
    reached = sum(1 for stamp, _, bhp in run.predictions
                  if len(bhp) > 1 and stamp + seconds_to_ns(1.0) <= end_ns)
    assert errors["run"]["1s"]["count"] == reached > 200
    assert {MOVING, PUMP_DOWN, CONNECTION} <= set(errors)
    assert sum(e["1s"]["count"] for g, e in errors.items() if g != "run") == reached
    assert all(e["1s"]["rms_pa"] < 2.0 * BAR for e in errors.values())


def test_a_bad_setting_is_refused_with_its_key_before_any_trip(capsys):
    """``--set`` changes the model's side; an unknown key stops the command with the file,
    the key and the keys allowed, before anything runs."""
    from drill_studies.trip_bench import main
    with pytest.raises(SystemExit) as stop:
        main(["--stands", "1", "--set", "nmpc.floor_pump_on_shar=0.3"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "nmpc.yaml" in err and "floor_pump_on_shar" in err and "floor_pump_on_share" in err


def test_a_ramp_share_out_of_range_is_refused_with_its_range(capsys):
    from drill_studies.trip_bench import main
    with pytest.raises(SystemExit) as stop:
        main(["--stands", "1", "--pump-stop-share", "1.3"])
    assert stop.value.code == 2
    assert "trip.pump_stop_share: value 1.3 is outside the allowed range [0, 0.95]" \
        in capsys.readouterr().err
