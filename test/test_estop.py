"""Integration over DDS, fast mode: the emergency stop, pressed by a scenario's operator
actions (drill_core.operator_actions) at rest, while pulling out at the trip's full speed
and while running in (test/scenarios/estop_trip.yaml), during a mud-pump trip
(estop_pump_trip.yaml) and during a kick answer (estop_kick.yaml), each held 60 s:

* /rig/command says so from the stamp of the press for as long as it is held;
* the drawworks brakes the block to rest within its brake time (v / a plus a frame) and
  holds it there, within 0.3 m of where it was at the press; the string settles within
  0.3 m of where it was;
* the choke holds the BHP of the stop (the command's emergency_bhp_pa): within 2 bar for
  the 60 s at rest and in the kick answer; after a stop at speed, once the surge or swab
  that stops with the string has gone through (its transient is bounded here; how large
  and why: docs/faults.md), and inside the pore/fracture window throughout; during a pump
  trip inside the window;
* the release hands back without a jump: the block reference goes on from where the
  string is, at the protection's acceleration limit;
* each press and release is on /protection/events at its stamp, marked as the scenario's.
"""
import math
from pathlib import Path

import numpy as np
import pytest

from drill_bringup import cli, mcap_io, report
from drill_core.config import load_rig
from drill_core.ros import topics

pytestmark = [pytest.mark.dds, pytest.mark.slow]
SCENARIOS = Path(__file__).resolve().parent / "scenarios"
CONFIG = load_rig(cli.ROOT / "config")
HOLD_S = 60.0
FRAME_S = CONFIG.plant.sensor_period_s
MOVING_TRANSIENT_PA = 10.0e5        # bound on a stop at speed's transient (measured: 6-8 bar)
MOVING_SETTLED_S = 30.0             # ... after which it holds within 2 bar (measured: 21-25 s)


def _run(tmp_path_factory, name: str, domain_id: int):
    code, run_dir = cli.run_scenario(SCENARIOS / f"{name}.yaml",
                                     runs_dir=tmp_path_factory.mktemp(name),
                                     domain_id=domain_id, timeout_s=600, quiet=True)
    assert code == 0, (run_dir / "launch.json").read_text()
    path = next(run_dir.glob("*.mcap"))
    commands = {round(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, 3): m
                for _, m in mcap_io.decoded_messages(path, [topics.MACHINE_COMMAND])}
    return report.load_series(path), commands


@pytest.fixture(scope="module")
def trip(tmp_path_factory):
    return _run(tmp_path_factory, "estop_trip", 89)


@pytest.fixture(scope="module")
def pump_trip(tmp_path_factory):
    return _run(tmp_path_factory, "estop_pump_trip", 89)


@pytest.fixture(scope="module")
def kick(tmp_path_factory):
    return _run(tmp_path_factory, "estop_kick", 89)


def _stop(run, press_s: float):
    """What the stop pressed at ``press_s`` did over its 60 s: the block's speed at the
    press, its travel, when it came to rest, the string's spread about where it was,
    the BHP's deviation from the stop's target per frame (with times), and the target."""
    series, commands = run
    held = [commands[k] for k in sorted(commands) if press_s <= k < press_s + HOLD_S]
    assert held and all(c.emergency_stop for c in held), "the brake and the BHP hold in force"
    target = held[0].emergency_bhp_pa
    assert all(c.emergency_bhp_pa == target for c in held)
    t, block = series.get("block")
    _, string = series.get("position")
    _, bhp = series.get("bhp")
    at = int(np.searchsorted(t, press_s))
    window = (t >= press_s) & (t <= press_s + HOLD_S)
    speed = np.abs(np.diff(block)) / np.diff(t)
    still = np.flatnonzero((speed < 1e-9) & window[1:])
    rest_s = t[still[0] + 1] if still.size else math.inf
    return dict(speed=speed[at - 2], travel=np.abs(block[window] - block[at]).max(),
                rest_s=rest_s - press_s, block_after=np.ptp(block[window & (t >= rest_s)]),
                string=np.abs(string[window] - string[at]).max(),
                string_settled=abs(np.mean(string[window & (t > press_s + HOLD_S - 10.0)])
                                   - string[at]),
                bhp_t=t[window] - press_s, bhp_dev=bhp[window] - target, target=target,
                bhp=bhp[window])


def _brakes(stop):
    brake_s = stop["speed"] / CONFIG.actuators.brake_deceleration_mps2
    assert stop["rest_s"] <= brake_s + 2 * FRAME_S, stop["rest_s"]
    assert stop["block_after"] == 0.0                # held where it came to rest
    assert stop["travel"] < 0.3 and stop["string_settled"] < 0.3


def _inside_the_window(bhp):
    f = CONFIG.well.formation
    assert np.all((bhp >= f.pore_pressure_pa) & (bhp <= f.fracture_pressure_pa))


def test_at_rest_the_stop_holds_block_and_bhp(trip):
    stop = _stop(trip, 10.0)
    _brakes(stop)
    assert np.abs(stop["bhp_dev"]).max() < 2.0e5


@pytest.mark.parametrize("press_s", (96.0, 236.0), ids=("pulling_out", "running_in"))
def test_at_full_speed_the_block_brakes_and_the_bhp_of_the_stop_is_held(trip, press_s):
    stop = _stop(trip, press_s)
    assert stop["speed"] > 0.35     # at the speed the NMPC trips at (about 0.4 and 0.5 m/s)
    _brakes(stop)
    assert stop["string"] < 0.4                      # the string's ring on its stretch
    dev, when = stop["bhp_dev"], stop["bhp_t"]
    assert np.abs(dev).max() < MOVING_TRANSIENT_PA
    assert np.abs(dev[when >= MOVING_SETTLED_S]).max() < 2.0e5
    _inside_the_window(stop["bhp"])


def test_the_release_hands_back_without_a_jump(trip):
    series, commands = trip
    stamps = sorted(commands)
    period = CONFIG.protection.command_period_s
    step = CONFIG.protection.trip_acceleration_max_mps2 * period * period
    for release_s in (75.0, 161.0, 301.0):
        last = commands[max(k for k in stamps if k < release_s)]
        first = commands[min(k for k in stamps if k >= release_s)]
        assert last.emergency_stop and not first.emergency_stop
        assert abs(first.block_position_ref_m - last.block_position_ref_m) <= step + 0.05
    t, block = series.get("block")
    jumps = np.abs(np.diff(block))
    assert jumps.max() <= CONFIG.actuators.drawworks.rate_limit_per_s * FRAME_S + 1e-9


def test_every_press_is_recorded_as_the_scenarios(trip):
    series, _ = trip
    presses = [(round(e[0], 1), e[3]) for e in series.events
               if e[1] == "protection" and e[2] == "emergency_stop"]
    assert [p[0] for p in presses] == [10.0, 75.0, 96.0, 161.0, 236.0, 301.0]
    assert all("scenario operator action" in p[1] for p in presses)
    assert [p[1].split(" (")[0] for p in presses[:2]] == ["emergency stop engaged",
                                                          "emergency stop released"]


def test_during_a_pump_trip_the_stop_holds_the_block_and_the_window(pump_trip):
    stop = _stop(pump_trip, 10.0)
    _brakes(stop)
    _inside_the_window(stop["bhp"])


def test_during_a_kick_answer_the_stop_holds_the_bhp(kick):
    series, _ = kick
    alarms = [e[0] for e in series.events if e[1] == "protection" and e[2] == "alarm"
              and e[3].startswith("kick detected")]
    assert alarms and alarms[0] < 112.0              # pressed while the answer stands
    stop = _stop(kick, 112.0)
    _brakes(stop)
    assert np.abs(stop["bhp_dev"]).max() < 2.0e5
    _inside_the_window(stop["bhp"])
