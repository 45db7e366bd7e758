"""rig sweep without DDS: --set parsing and validation, the plan, resume with a fake run,
aggregation on synthetic summaries, the runner's pool and worker domains, and rig compare
getting its runs through the same runner."""
import json
import threading
from dataclasses import replace
from pathlib import Path

import pytest

from drill_bringup import launcher, runs
from drill_studies import batch, compare, sweep
from drill_studies.batch import RunSpec
from drill_core.config import ConfigError, parse_settings
from drill_core.scenario import load_scenario_config

SHORT = runs.ROOT / "config" / "scenarios" / "short_trip.yaml"


def summary(bhp_rmse_bar, legs=(30.0, 31.0), fallbacks=None, solves=0):
    s = {"bhp_rmse_pa": bhp_rmse_bar * 1e5, "bhp_time_outside_s": 2.0 * bhp_rmse_bar,
         "bhp_time_outside_settled_s": 0.0, "bhp_worst_excursion_pa": 3e5 * bhp_rmse_bar,
         "max_string_speed_mps": 0.5, "bhp_estimate_rmse_pa": 0.2e5, "trip_overshoot_m": 0.1,
         "trip_legs": [[8.0, legs[0]], [0.0, legs[1]]]}
    if solves:
        s.update(solves=solves, fallbacks=fallbacks, solve_time_median_s=0.01,
                 solve_time_p99_s=0.02, solve_time_max_s=0.03)
    return s


class FakeRun:
    """Writes what run_scenario would (launch.json, summary.json) into the spec's runs_dir;
    remembers what it ran; fails the seeds it is told to."""

    def __init__(self, failing=()):
        self.ran, self.failing = [], set(failing)

    def __call__(self, spec: RunSpec) -> dict:
        self.ran.append((spec.controller, spec.seed))
        run_dir = Path(spec.runs_dir) / f"run-{len(self.ran)}"
        run_dir.mkdir(parents=True)
        ok = spec.seed not in self.failing
        (run_dir / "launch.json").write_text(json.dumps(
            {"ok": ok, "message": "scenario finished" if ok else "node 'plant' exited with code 1",
             "wall_time_s": 10.0}))
        if ok:
            (run_dir / "summary.json").write_text(json.dumps(summary(0.1 * spec.seed)))
        return batch.result_row(spec, run_dir)


def test_set_items_become_nested_overrides_with_clear_errors():
    assert parse_settings(["nmpc.bhp_bias_gain=0", "plant.measurement_noise.bhp_pa=1.5e4",
                           "nmpc.configuration=NMPC2", "protection.window_guard=false"]) == {
        "nmpc": {"bhp_bias_gain": 0, "configuration": "NMPC2"},
        "plant": {"measurement_noise": {"bhp_pa": 1.5e4}}, "protection": {"window_guard": False}}
    with pytest.raises(ConfigError, match="expected FILE.KEY=VALUE"):
        parse_settings(["nmpc.bhp_bias_gain"])
    with pytest.raises(ConfigError, match="'nmcp' is not a configuration file; one of well, "):
        parse_settings(["nmcp.bhp_bias_gain=0"])


def test_sweep_scenario_carries_the_overrides_to_every_node_and_checks_them(tmp_path):
    path = sweep.sweep_scenario(SHORT, ["plant.measurement_noise.bhp_pa=0"], tmp_path)
    scenario, config = load_scenario_config(path, runs.ROOT / "config")   # what nodes load
    assert config.plant.measurement_noise.bhp_pa == 0.0
    assert config.nmpc.configuration == "NMPC1"           # the scenario's own override kept
    assert scenario.name == "short_trip"
    with pytest.raises(ConfigError, match=r"bhp_pa: value -1.0 is outside the allowed range"):
        sweep.sweep_scenario(SHORT, ["plant.measurement_noise.bhp_pa=-1.0"], tmp_path / "b")
    with pytest.raises(ConfigError, match=r"unknown key\(s\) bhp_gain; allowed: "):
        sweep.sweep_scenario(SHORT, ["nmpc.bhp_gain=1"], tmp_path / "c")
    assert not (tmp_path / "b").exists()
    with pytest.raises(ConfigError, match="holds a sweep of other settings"):
        sweep.sweep_scenario(SHORT, [], tmp_path)
    assert sweep.sweep_scenario(SHORT, ["plant.measurement_noise.bhp_pa=0"], tmp_path) == path


def test_plan_is_every_controller_on_consecutive_seeds(tmp_path):
    specs = sweep.plan("short_trip", SHORT, ["nmpc", "baseline"], 3, 7, tmp_path)
    assert [(s.controller, s.seed) for s in specs] == [
        ("nmpc", 7), ("nmpc", 8), ("nmpc", 9), ("baseline", 7), ("baseline", 8), ("baseline", 9)]
    assert {Path(s.runs_dir) for s in specs} == {tmp_path / f"{c}-seed{n}" for c in
                                                 ("nmpc", "baseline") for n in (7, 8, 9)}
    with pytest.raises(ConfigError, match="--seeds: value 0 must be at least 1"):
        sweep.plan("short_trip", SHORT, ["nmpc"], 0, 7, tmp_path)


def test_a_sweep_resumes_where_it_stopped(tmp_path):
    fake = FakeRun(failing={8})
    quiet = lambda text: None      # noqa: E731
    code = sweep.sweep("short_trip", 2, 7, ["baseline"], output=tmp_path, run=fake, say=quiet)
    assert code == 1 and fake.ran == [("baseline", 7), ("baseline", 8)]
    index = json.loads((tmp_path / sweep.INDEX_FILE).read_text())
    assert [(r["seed"], r["ok"]) for r in index["runs"]] == [(7, True), (8, False)]
    assert "baseline seed 8: node 'plant' exited" in (tmp_path / sweep.TABLE_FILE).read_text()

    fake = FakeRun()                            # the same command again, one seed more
    assert sweep.sweep("short_trip", 3, 7, ["baseline"], output=tmp_path, run=fake,
                       say=quiet) == 0
    assert fake.ran == [("baseline", 8), ("baseline", 9)]       # seed 7 was done
    index = json.loads((tmp_path / sweep.INDEX_FILE).read_text())
    assert [(r["seed"], r["ok"]) for r in index["runs"]] == [(7, True), (8, True), (9, True)]
    assert index["seeds"] == [7, 8, 9] and index["controllers"] == ["baseline"]
    assert (tmp_path / sweep.PLOT_FILE).stat().st_size > 0
    with pytest.raises(ConfigError, match="holds a sweep of other settings"):
        sweep.sweep("short_trip", 3, 7, ["baseline"], ["nmpc.bhp_bias_gain=0"],
                    output=tmp_path, run=FakeRun(), say=quiet)


def _row(controller, seed, s, ok=True):
    return {"case": "case2", "controller": controller, "seed": seed, "ok": ok,
            "message": "", "run_dir": f"/r/{seed}", "wall_s": 1.0, "summary": s if ok else None}


def test_aggregation_gives_mean_spread_and_worst_per_controller():
    rows = [_row("nmpc", 1, summary(0.2, solves=600, fallbacks=0)),
            _row("nmpc", 2, summary(0.4, legs=(33.0, None), solves=600, fallbacks=6)),
            _row("nmpc", 3, None, ok=False),
            _row("baseline", 1, summary(1.0)),
            _row("baseline", 2, {**summary(2.0), "detection": {"kick": {"false_alarms": 3}}})]
    stats = sweep.aggregate(rows)
    rmse = stats["nmpc"]["bhp_rmse_pa"]
    assert rmse["mean"] == pytest.approx(0.3e5) and rmse["std"] == pytest.approx(0.1e5)
    assert rmse["worst"] == pytest.approx(0.4e5) and rmse["runs"] == 2
    assert stats["nmpc"]["leg_in_s"] == {"mean": 31.0, "std": 0.0, "worst": 31.0, "runs": 1,
                                         "missing": 1}
    assert stats["nmpc"]["fallback_share"]["worst"] == pytest.approx(0.01)
    assert stats["baseline"]["fallbacks"]["missing"] == 2
    index = {"scenario": "case2", "scenario_file": "/c/config/scenarios/case2.yaml",
             "seeds": [1, 2, 3], "overrides": {"nmpc": {"bhp_bias_gain": 0}},
             "controllers": ["nmpc", "baseline"], "mismatch_draws": 4, "runs": rows}
    text = sweep.markdown(index, stats, workers=2, picture="sweep.png")
    assert "| figure | nmpc | baseline |" in text
    assert "| BHP RMSE [bar] | 0.300 ± 0.100 (worst 0.400) | 1.500 ± 0.500 (worst 2.000) |" in text
    assert "| leg in [s] | 31.0 ± 0.0 (worst 31.0), 1 none |" in text
    assert "| fallbacks / solves [%] | 0.500 ± 0.500 (worst 1.000) |" in text
    assert "| solve p99 [ms] | 20.0 ± 0.0 (worst 20.0) |" in text
    assert "4 of 5 runs finished" in text and "- nmpc seed 3:" in text
    assert "| false alarms [1] | 0.000 ± 0.000 (worst 0.000) | 1.500 ± 1.500 (worst 3.000) |" in text
    assert "2 runs at a time shared the cores" in text and "](sweep.png)" in text
    assert ("Command: `scripts/rig sweep case2 --seeds 3 --first-seed 1 --controller nmpc "
            "baseline --mismatch-draws 4 --set nmpc.bhp_bias_gain=0`") in text


def test_display_units_follow_the_key_suffix():
    assert sweep.display("bhp_rmse_pa") == ("bar", 1e-5)
    assert sweep.display("choke_flow_m3s") == ("L/min", 60000.0)
    assert sweep.display("solve_p99_s") == ("ms", 1e3)
    assert sweep.display("leg_out_s") == ("s", 1.0)


def test_the_process_pool_keeps_the_plan_order(tmp_path):
    specs = [RunSpec("c", "s.yaml", "nmpc", seed) for seed in range(4)]
    seen = []
    rows = batch.execute(specs, run=repr, workers=2, on_done=seen.append)
    # runs at once: none of them pins CPUs (launcher.cpu_sets)
    assert rows == [repr(replace(s, alone=False)) for s in specs] and sorted(seen) == sorted(rows)
    assert batch.execute(specs[:1], run=repr, workers=2) == [repr(specs[0])]    # alone
    with pytest.raises(ValueError, match="--workers: value 0 must be at least 1"):
        batch.execute(specs, run=repr, workers=0)


def test_each_worker_thread_keeps_one_domain_of_its_own(monkeypatch):
    taken = iter(range(1, 40))
    monkeypatch.setattr(launcher, "default_domain_id", lambda: next(taken))
    monkeypatch.setattr(batch, "_worker", threading.local())
    mine = [batch.worker_domain(), batch.worker_domain()]
    other = []
    thread = threading.Thread(target=lambda: other.extend([batch.worker_domain()] * 2))
    thread.start()
    thread.join()
    assert mine == [1, 1] and other == [2, 2]


def test_compare_gets_its_runs_through_the_sweep_runner(tmp_path, capsys):
    fake = FakeRun()
    items = [("short_trip", "nmpc", 7), ("short_trip", "baseline", 7)]
    rows = compare.run_all(items, runs_dir=tmp_path, run=fake)
    assert fake.ran == [("nmpc", 7), ("baseline", 7)]
    assert [list(r) for r in rows] == [["case", "controller", "seed", "mismatch", "summary",
                                        "run_dir", "wall_s", "commit"]] * 2
    assert rows[0]["mismatch"] is None
    assert rows[0]["summary"]["bhp_rmse_pa"] == pytest.approx(0.7e5)
    assert "short_trip / baseline / seed 7: BHP RMSE 0.700 bar" in capsys.readouterr().out
    with pytest.raises(RuntimeError, match="short_trip / nmpc / seed 7 failed: node 'plant'"):
        compare.run_all(items, runs_dir=tmp_path / "again", run=FakeRun(failing={7}))


def test_mismatch_draws_put_every_run_on_each_draws_plant(tmp_path):
    specs = sweep.plan("short_trip", SHORT, ["baseline"], 2, 7, tmp_path, mismatch_draws=3)
    assert [(s.seed, s.mismatch) for s in specs] == [
        (seed, f"draw:{i}") for seed in (7, 8) for i in range(3)]
    assert Path(specs[1].runs_dir) == tmp_path / "baseline-seed7-draw1"
    fake = FakeRun()
    quiet = lambda text: None      # noqa: E731
    assert sweep.sweep("short_trip", 2, 7, ["baseline"], output=tmp_path, run=fake, say=quiet,
                       mismatch_draws=3) == 0
    index = json.loads((tmp_path / sweep.INDEX_FILE).read_text())
    assert [r["mismatch"] for r in index["runs"]] == ["draw:0", "draw:1", "draw:2"] * 2
    assert index["mismatch_draws"] == 3
    assert "mismatch draws 0..2" in (tmp_path / sweep.TABLE_FILE).read_text()
    with pytest.raises(ConfigError, match="--mismatch-draws: value -1"):
        sweep.plan("short_trip", SHORT, ["baseline"], 1, 7, tmp_path, mismatch_draws=-1)
