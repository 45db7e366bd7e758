"""The sweep bench's figures against a hand calculation (drill_studies.sweep_bench)."""
import pytest

from drill_studies import sweep_bench


def test_efficiency_and_overheads_by_hand():
    # 4 runs of 40 s graph + 5 s report each on 2 workers, done in 100 s; alone a run takes 40 s
    rows = [{"ok": True, "wall_s": 40.0, "worker_s": 45.0} for _ in range(3)] + \
        [{"ok": False, "wall_s": None, "worker_s": 5.0}]
    f = sweep_bench.figures("pool", 100.0, rows, 2, 40.0, 50.0)
    assert f["ideal_wall_s"] == pytest.approx(80.0)                   # 40 s x 4 / 2
    assert f["cpu_bound_wall_s"] == pytest.approx(100.0)              # 50 s x 4 / 2
    assert f["efficiency_ceiling"] == pytest.approx(0.8)
    assert f["efficiency"] == pytest.approx(0.8)
    assert f["runs_per_hour"] == pytest.approx(144.0)
    assert f["outside_graph_per_run_s"] == pytest.approx((140.0 - 120.0) / 4)
    assert f["scheduler_overhead_per_run_s"] == pytest.approx((200.0 - 140.0) / 4)
    assert f["failed"] == 1 and f["run_graph_median_s"] == 40.0


def test_the_section_says_whether_the_goal_was_met():
    rows = [{"ok": True, "wall_s": 40.0, "worker_s": 41.0}] * 2
    met = sweep_bench.figures("pool", 41.0, rows, 2, 40.0, 40.0)
    missed = sweep_bench.figures("Dask", 60.0, rows, 2, 40.0, 40.0)
    text = "\n".join(sweep_bench.markdown([met, missed], "case2", "nmpc", 40.0, 40.0))
    assert "0.98 (met; 1.00)" in text and "0.67 (missed; 1.00)" in text
