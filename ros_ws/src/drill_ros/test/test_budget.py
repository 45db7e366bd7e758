"""The time budget of a run's processes (drill_ros.budget)."""
import json

import pytest

from drill_ros.budget import BUDGET_DIR_ENV, NodeBudget, ProcessClock, markdown, summarise


def test_budget_files_are_written_where_the_launcher_asks(tmp_path, monkeypatch):
    monkeypatch.delenv(BUDGET_DIR_ENV, raising=False)
    assert ProcessClock().write("p", {}) is None              # not asked: nothing written
    monkeypatch.setenv(BUDGET_DIR_ENV, str(tmp_path / "budget"))
    clock = ProcessClock()
    clock.spinning()
    path = clock.write("plant", {"plant": NodeBudget(3, 0.5, 0.4, 0.1)})
    data = json.loads(path.read_text())
    assert path.name == "plant.json" and data["nodes"]["plant"]["callbacks"] == 3
    assert data["wall_s"] >= 0.0 and data["startup_s"] >= 0.0


def test_summary_splits_the_wall_time(tmp_path):
    (tmp_path / "control.json").write_text(json.dumps({
        "process": "control", "startup_s": 1.0, "wall_s": 10.0, "cpu_s": 6.0,
        "nodes": {"estimator": {"callbacks": 10, "callback_s": 4.0, "callback_cpu_s": 3.0,
                                "publish_cpu_s": 0.5},
                  "nmpc": {"callbacks": 1, "callback_s": 2.0, "callback_cpu_s": 2.0,
                           "publish_cpu_s": 0.5}}}))
    (row,) = summarise(tmp_path)
    assert row["nodes"] == "estimator, nmpc"
    assert row["idle_s"] == pytest.approx(4.0)          # wall - CPU
    assert row["executor_s"] == pytest.approx(1.0)      # CPU - callback CPU
    assert row["compute_s"] == pytest.approx(4.0)       # callback CPU - publish CPU
    assert row["publish_s"] == pytest.approx(1.0)
    assert row["preempted_s"] == pytest.approx(1.0)     # callback wall - callback CPU
    table = markdown([row])
    assert "| control | estimator, nmpc | 1.0 | 10.0 | 6.0 | 4.0 | 1.0 | 4.0 | 1.0 | 1.0 |" in table
