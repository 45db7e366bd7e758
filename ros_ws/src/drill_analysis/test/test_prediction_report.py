"""The NMPC's prediction errors from solves and truth samples made up with known errors."""
import math

from drill_analysis import prediction_report as pr

NS = 1_000_000_000


def truth(seconds: int) -> dict:
    """A BHP rising 1 bar a second from 685 bar, sampled every second [Pa]."""
    return {k * NS: 6.85e7 + 1.0e5 * k for k in range(seconds)}


def solve(at_s: int, offsets_pa: dict, bhp=None) -> tuple:
    """A solve at ``at_s`` predicting 0-5 s ahead: the truth plus ``offsets_pa`` by horizon."""
    bhp = bhp or truth(100)
    times = [float(k) for k in range(6)]
    return at_s * NS, times, [bhp[(at_s + k) * NS] + offsets_pa.get(k, 0.0) for k in range(6)]


def test_the_errors_are_the_predictions_less_the_truth_by_phase_and_horizon():
    solves = [solve(10, {1: 2.0e5, 5: -1.0e5}), solve(11, {1: -2.0e5, 5: -3.0e5}),
              solve(20, {1: 1.0e5, 5: 1.0e5})]
    phases = {10 * NS: "pump_down", 11 * NS: "pump_down", 20 * NS: "moving"}
    e = pr.prediction_errors(solves, truth(100), phases)
    down, run = e["pump_down"], e[pr.RUN]
    assert down["1s"]["count"] == 2 and abs(down["1s"]["mean_pa"]) < 1e-6
    assert math.isclose(down["1s"]["rms_pa"], 2.0e5) and math.isclose(down["5s"]["mean_pa"], -2.0e5)
    assert math.isclose(down["5s"]["rms_pa"], math.sqrt((1.0e10 + 9.0e10) / 2))
    assert run["1s"]["count"] == 3 and math.isclose(run["1s"]["mean_pa"], 1.0e5 / 3)
    assert math.isclose(e["moving"]["5s"]["mean_pa"], 1.0e5)
    lines = pr.format_rows(e)
    assert "1 s ahead, 5 s ahead" in lines[0]
    assert [line.split()[0] for line in lines[1:]] == [pr.RUN, "moving", "pump_down"]
    assert "+0.00 / 2.00" in lines[3] and "-2.00 / 2.24" in lines[3]


def test_a_prediction_past_the_recording_a_hold_and_a_nan_are_left_out():
    bhp = truth(100)
    predicted_past_the_end = bhp | {k * NS: 0.0 for k in range(100, 103)}
    late = solve(97, {1: 1.0e5}, predicted_past_the_end)   # 5 s ahead: after the last sample
    hold = (30 * NS, [], [])                          # a held input: no prediction
    nan = (40 * NS, [0.0, 1.0], [bhp[40 * NS], float("nan")])
    e = pr.prediction_errors([late, hold, nan], bhp)
    assert e[pr.RUN]["1s"]["count"] == 1 and "5s" not in e[pr.RUN]
    assert pr.prediction_errors([hold], bhp) == {}


def test_a_runs_truth_in_seconds_meets_the_solves_stamps():
    """A recording's stamps as float seconds (sec + nanosec 1e-9) find the solves' ns
    stamps again, far into a long run."""
    start_s = 2400
    bhp = {(start_s + k) * NS + 100_000_000: 6.85e7 + 1.0e4 * k for k in range(8)}
    times_s = [(stamp // NS) + (stamp % NS) * 1e-9 for stamp in bhp]
    stamp = start_s * NS + 100_000_000
    solve_ = (stamp, [0.0, 1.0, 5.0], [bhp[stamp], bhp[stamp + NS] + 3.0e4, bhp[stamp + 5 * NS]])
    e = pr.errors_over_run([solve_], times_s, list(bhp.values()), {stamp: "moving"})
    assert e["moving"]["1s"] == {"mean_pa": 3.0e4, "rms_pa": 3.0e4, "count": 1}
    assert e[pr.RUN]["5s"]["count"] == 1 and e[pr.RUN]["5s"]["mean_pa"] == 0.0
