"""The machines' bound of a fault-matrix cell: the fastest answer's machine command, the
runs it is taken for, and its column and speed envelope on the page (no run)."""
import json
import math
from dataclasses import dataclass, replace

from drill_studies import fault_bound as fb
from drill_studies import fault_matrix as fm

FIGURES = {"bhp_over_fracture_s": 0.0, "worst_underbalance_pa": 2.0e5,
           "worst_overbalance_over_fracture_pa": 0.0, "bhp_worst_excursion_pa": 2.0e5,
           "influx_volume_m3": 0.0, "loss_volume_m3": 0.0, "protection_events": 1,
           "false_alarms": 0}


@dataclass(frozen=True)
class Command:
    emergency_stop: bool = False
    emergency_bhp_pa: float = math.nan
    bpp_flow_m3s: float = 0.0
    choke_dp_ref_pa: float = 0.0
    choke_manual: bool = True
    choke_pressure_control: bool = True
    choke_opening_ref: float = 0.5
    block_position_ref_m: float = 3.5


@dataclass(frozen=True)
class Measurement:
    choke_dp_pa: float
    bhp_pa: float = 6.9e7
    block_position_m: float = 3.0


def test_the_brake_answer_acts_from_the_fault_on_only():
    machines = fb.brake_answer(20.0, 0.025, 6.85e7)
    before = Command()
    assert machines(19.9, Measurement(2.5e6), before) is before
    after = machines(20.0, Measurement(2.5e6), before)
    assert after == Command(emergency_stop=True, emergency_bhp_pa=6.85e7, bpp_flow_m3s=0.025,
                            choke_dp_ref_pa=2.5e6, choke_manual=False,
                            choke_pressure_control=False)
    blank = machines(21.0, Measurement(math.nan), replace(before, choke_dp_ref_pa=1.0e6))
    assert blank.choke_dp_ref_pa == 1.0e6            # a blank gauge: the command's own


def test_the_shut_answer_shuts_the_choke_while_the_bhp_is_under_the_target_once():
    """Above the target the brake answer; from the first BHP under it the choke shut, the
    back-pressure pump at its maximum and the block held where the string was then (no
    brake); once the BHP is back at the target the brake answer for good."""
    machines = fb.shut_answer(21.0, 0.025, 6.85e7)
    before = Command()
    assert machines(20.0, Measurement(2.5e6, bhp_pa=6.6e7), before) is before
    assert machines(21.0, Measurement(2.5e6), before).emergency_stop
    shut = machines(22.0, Measurement(2.5e6, bhp_pa=6.7e7, block_position_m=4.0),
                    replace(before, emergency_stop=True))
    assert (shut.emergency_stop, shut.choke_manual, shut.choke_opening_ref, shut.bpp_flow_m3s,
            shut.block_position_ref_m) == (False, True, 0.0, 0.025, 4.0)
    still = machines(23.0, Measurement(2.5e6, bhp_pa=6.7e7, block_position_m=4.2), before)
    assert still.block_position_ref_m == 4.0          # held where the string was
    assert machines(24.0, Measurement(2.5e6, bhp_pa=6.86e7), before).emergency_stop
    assert machines(25.0, Measurement(2.5e6, bhp_pa=6.7e7), before).emergency_stop


def test_the_answers_start_at_the_first_command_that_can_see_the_fault():
    assert fb.first_command_after(20.0, 1.0) == 21.0      # that command reads the frame before
    assert fb.first_command_after(20.3, 1.0) == 21.0
    assert fb.first_command_after(85.0, 0.5) == 85.5


def row(phase, faults, controller, under, **extra):
    return {"phase": phase, "faults": list(faults), "controller": controller, "seed": 2,
            "run_dir": None, "bhp_under_pore_s": under, **FIGURES, **extra}


def test_each_run_that_left_the_window_is_bounded_after_its_own_controller():
    both, one = ("pull-out", ("choke stuck", "mud pump trip")), ("pull-out", ("BPP trip",))
    rows = [row(*both, c, 5.0) for c in fm.CONTROLLERS] \
        + [row(*one, c, 2.0 if c == "baseline" else 0.0) for c in fm.CONTROLLERS] \
        + [row(*both, fm.BOUND, 1.0, speed_mps=0.5, prefix="nmpc")]
    assert fb.runs_left(rows) == [(*both, c) for c in fm.CONTROLLERS] + [(*one, "baseline")]


def test_the_page_shows_the_bound_column_and_the_envelope():
    cell = ("pull-out", ("choke stuck", "mud pump trip"))
    speed = fm.cell_speed_mps()
    rows = [row(*cell, c, 9.5) for c in fm.CONTROLLERS] + [row("rest", ("BHP dropout",), c, 0.0)
                                                           for c in fm.CONTROLLERS]
    rows += [row(*cell, fm.BOUND, under, speed_mps=v, prefix="automated_mpd", answer="brake",
                 start_s=21.0) for v, under in ((speed, 0.0), (0.3, 1.5))]
    rows += [row(*cell, fm.BOUND, 9.5, speed_mps=speed, prefix="baseline", answer="shut",
                 start_s=21.0)]
    page = fm.markdown(rows, "now", (6.6e7, 7.1e7))
    assert f"**3 of {len(rows) - 3} runs left the window.**" in page   # bounds are not runs
    assert "| phase | faults | nmpc | automated_mpd | baseline | bound |" in page
    assert "| pull-out | choke stuck + mud pump trip | **9.5 s under (2.0 bar)** | " \
           "**9.5 s under (2.0 bar)** | **9.5 s under (2.0 bar)** | after automated_mpd " \
           "(brake from 21 s): 0; after baseline (shut from 21 s): **9.5 s under (2.0 bar)** |" \
           in page
    # the NMPC's run has no bound, automated MPD's is 0: past theirs; the baseline's at it
    assert "**2 of them left it for longer than their bound**: pull-out, choke stuck + mud " \
           "pump trip, nmpc; pull-out, choke stuck + mud pump trip, automated_mpd." in page
    assert "| rest | BHP dropout | 0 | 0 | 0 | – |" in page
    assert "*pull-out, choke stuck + mud pump trip, after automated_mpd*" in page
    assert f"| {speed:g} m/s | 0 |" in page and "| 0.3 m/s | **1.5 s under (2.0 bar)** |" in page
    assert "*pull-out, choke stuck + mud pump trip, after baseline*" in page


def test_a_string_at_rest_is_bounded_at_its_own_speed_only(tmp_path, monkeypatch):
    output = tmp_path / "fault-matrix.md"
    left = [("rest", ("choke stuck", "mud pump trip")), ("run-in", ("BPP trip", "mud pump trip"))]
    rows = [row(*cell, "baseline", 3.0) for cell in left]
    output.with_suffix(".json").write_text(json.dumps(rows))
    asked = []

    def fake_bound(phase, faults, speed_mps, prefix):
        asked.append((phase, speed_mps))
        return row(phase, faults, fm.BOUND, 1.0, speed_mps=speed_mps, prefix=prefix,
                   answer="brake", start_s=21.0)
    monkeypatch.setattr(fb, "bound", fake_bound)
    fb.main(output, speeds=(0.3, 0.1))
    speed = fm.cell_speed_mps()
    assert asked == [("rest", speed), ("run-in", speed), ("run-in", 0.3), ("run-in", 0.1)]
    assert len(json.loads(output.with_suffix(".json").read_text())) == len(rows) + len(asked)
