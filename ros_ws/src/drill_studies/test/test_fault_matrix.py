"""The fault matrix's plan and page, without running a graph: the cells (each fault alone and
the pairs asked for, in each phase), valid scenarios with the faults at the phase's fault
time, rows per run, a table written after every run that a resumed matrix completes, and a
page that marks every cell outside the window."""
import itertools
import json
import shutil
from datetime import datetime

import pytest
import yaml

from drill_studies import fault_matrix as fm
from drill_bringup import runs
from drill_core.scenario import load_scenario


def test_every_fault_alone_and_the_pairs_asked_for_in_every_phase():
    n, actuators = len(fm.FAULTS), len(fm.ACTUATOR_FAULTS)
    assert len(fm.cells("none")) == 3 * n
    assert len(fm.cells("actuators")) == 3 * (n + actuators * (actuators - 1) // 2)
    everything = fm.cells("all")
    assert len(everything) == 3 * (n + n * (n - 1) // 2) == len(set(everything))
    pairs = [faults for phase, faults in fm.cells("actuators") if len(faults) == 2]
    assert all(set(p) <= set(fm.ACTUATOR_FAULTS) for p in pairs)
    assert {phase for phase, faults in everything if len(faults) == 2} == set(fm.PHASES)
    # the pairs of actuator faults first: a matrix of every pair begins with them
    of_actuators = [set(f) <= set(fm.ACTUATOR_FAULTS) for _, f in everything if len(f) == 2]
    assert of_actuators == sorted(of_actuators, reverse=True)
    with pytest.raises(ValueError, match="expected one of none, actuators, all"):
        fm.cells("some")


def test_a_cell_is_a_valid_case2_scenario_with_its_faults_at_the_phase_time(tmp_path):
    written = fm.write_cells(tmp_path, fm.planned_cells("actuators"), fm.base_scenario())
    assert len({path for _, _, path in written}) == len(written)        # one file per cell
    assert [(phase, faults) for phase, faults, _ in written] == fm.cells("actuators")
    frozen = fm.planned_cells("all", ("BHP frozen",))
    assert frozen and all("BHP frozen" in faults for _, faults in frozen)
    assert len(frozen) == len(fm.PHASES) * len(fm.FAULTS)     # alone, and with each other one
    pair = fm.planned_cells("all", ("BHP frozen", "mud pump trip"))
    assert [set(faults) for _, faults in pair] == [{"BHP frozen", "mud pump trip"}] * len(fm.PHASES)
    base = yaml.safe_load(runs.scenario_path(fm.BASE_SCENARIO).read_text())
    for phase, faults, path in written:
        scenario, _ = load_scenario(path)             # validated like every scenario
        p = fm.PHASES[phase]
        assert scenario.duration_s == p.duration_s and scenario.seed == base["seed"]
        assert [e.time_s for e in scenario.events] == [p.fault_time_s] * sum(
            len(fm.FAULTS[f]) for f in faults)
        assert [(e.kind, e.target) for e in scenario.events] == [
            (e["kind"], e["target"]) for f in faults for e in fm.FAULTS[f]]
        targets = [s.block_position_target_m for s in scenario.schedule[1:]]
        assert targets == [t for _, t in p.targets]


def test_the_phases_put_the_fault_where_they_say():
    pull, rest, run_in = fm.PHASES["pull-out"], fm.PHASES["rest"], fm.PHASES["run-in"]
    assert pull.targets[0][0] < pull.fault_time_s and pull.targets[-1][1] > 0.0
    assert rest.targets == ()
    (out_at, out_to), (in_at, in_to) = run_in.targets
    assert out_at < in_at < run_in.fault_time_s and (out_to, in_to) == (28.0, 0.0)


def fake_run(spec):
    phase = next(p for p in fm.PHASES if spec.case.startswith(fm.cell_name(p, ())))
    under = 4.0 if (spec.controller == "baseline" and "trip" in spec.case) else 0.0
    return {"case": spec.case, "controller": spec.controller, "seed": spec.seed, "ok": True,
            "message": "", "run_dir": f"/runs/{spec.case}", "wall_s": 1.0,
            "summary": {"bhp_under_pore_s": under, "bhp_over_fracture_s": 0.0,
                        "worst_underbalance_pa": 2.5e5 if under else 0.0,
                        "worst_overbalance_over_fracture_pa": 0.0,
                        "bhp_worst_excursion_pa": 1.0e5, "influx_volume_m3": 0.0,
                        "loss_volume_m3": 0.0,
                        "events": [{"t_s": 20.0, "source": "protection", "kind": "alarm",
                                    "code": "window_exit", "value": 6.7e7, "text": phase}]}}


@pytest.fixture
def checkout(tmp_path, monkeypatch):
    """A checkout in tmp_path with this one's config: the cells' files go to its runs/."""
    shutil.copytree(runs.ROOT / "config", tmp_path / "config")
    monkeypatch.setattr(runs, "ROOT", tmp_path)
    return tmp_path


def test_rows_per_run_and_a_page_that_marks_each_cell_outside_the_window(checkout):
    rows = fm.run_matrix("none", run=fake_run)
    assert len(rows) == 3 * len(fm.FAULTS) * len(fm.CONTROLLERS)
    trips = [r for r in rows if any("trip" in f for f in r["faults"]) and r["controller"] == "baseline"]
    assert trips and all(r["bhp_under_pore_s"] == 4.0 and r["protection_events"] == 1 for r in trips)
    page = fm.markdown(rows, "now", (6.6e7, 7.1e7))
    assert "(660 and 710 bar)" in page and "the fault 15 s into the pull-out" in page
    outside = len(trips)
    assert f"**{outside} of {len(rows)} runs left the window.**" in page
    assert page.count("**4.0 s under (2.5 bar)**") == outside
    all_pairs = len(fm.PHASES) * len(list(itertools.combinations(fm.FAULTS, 2)))
    assert f"Pairs not run: {all_pairs} of the {all_pairs}" in page


def test_a_partial_run_replaces_its_cells_rows_and_keeps_the_others(checkout):
    output = checkout / "docs" / "fault-matrix.md"
    fm.main(output, "none", run=fake_run)
    before = json.loads(output.with_suffix(".json").read_text())
    fm.main(output, "none", ("mud pump trip",), ("automated_mpd",), run=fake_run)
    after = json.loads(output.with_suffix(".json").read_text())
    assert len(after) == len(before)
    rerun = after[-len(fm.PHASES):]             # the re-run cells' rows, last
    assert all("mud pump trip" in r["faults"] and r["controller"] == "automated_mpd" for r in rerun)
    fm.main(output, "none", controllers=("baseline",), run=fake_run)   # one controller's
    again = json.loads(output.with_suffix(".json").read_text())
    assert len(again) == len(before)
    assert all(r["controller"] == "baseline" for r in again[-len(again) // 3:])
    with pytest.raises(ValueError, match="fault 'pump trip'"):
        fm.main(output, "none", ("pump trip",), run=fake_run)


def test_the_page_says_when_its_runs_were_made_from_their_run_directories():
    assert runs.run_started("runs/fm-rest+bpp_trip-baseline-seed2-20261202-035551-13999") \
        == datetime(2026, 12, 2, 3, 55, 51)
    assert runs.run_started("/runs/fm-rest+bpp_trip") is None
    row = fake_run(fm.batch.RunSpec(fm.cell_name("rest", ("BPP trip",)), "", "nmpc", 2))
    figures = fm.cell_figures(row["summary"])
    rows = [{"phase": "rest", "faults": ["BPP trip"], "controller": c, "run_dir": d, **figures}
            for c, d in (("nmpc", "/r/fm-rest-seed2-20261202-045000-1"),
                         ("baseline", "/r/fm-rest-seed2-20261202-035300-1"))]
    page = fm.markdown(rows, "now", (6.6e7, 7.1e7))
    assert "The runs were made from 2026-12-02 03:53 to 2026-12-02 04:50" in page


def test_the_table_is_written_after_every_run_and_a_resumed_matrix_runs_only_what_it_lacks(checkout):
    output = checkout / "docs" / "fault-matrix.md"
    table = output.with_suffix(".json")
    calls = []

    def dies_after_five(spec):
        calls.append(spec)
        row = fake_run(spec)
        return row if len(calls) <= 5 else {**row, "ok": False, "message": "the graph died"}
    with pytest.raises(RuntimeError, match="the graph died"):
        fm.main(output, "none", run=dies_after_five)
    assert len(json.loads(table.read_text())) == 5          # every finished run is kept
    calls.clear()
    fm.main(output, "none", run=lambda spec: (calls.append(spec), fake_run(spec))[1], resume=True)
    rows = json.loads(table.read_text())
    assert len(calls) == len(rows) - 5 == 3 * len(fm.FAULTS) * len(fm.CONTROLLERS) - 5
    assert len({fm.row_key(r) for r in rows}) == len(rows)  # one row per cell and controller
    # a bound goes with the run it was made after: a re-run of that run drops it
    bound = {**rows[0], "controller": fm.BOUND, "prefix": rows[0]["controller"], "speed_mps": 0.5}
    table.write_text(json.dumps(rows + [bound], indent=1))
    phase, (fault,), controller = fm.row_key(rows[0])
    fm.main(output, "none", (fault,), (controller,), run=fake_run)
    again = json.loads(table.read_text())
    assert len(again) == len(rows) and fm.BOUND not in {r["controller"] for r in again}
