"""Integration over DDS: rig sweep runs whole graphs on a local process pool and on a Dask
cluster started here, each graph on a ROS domain of its own, with a --set override that
reaches the nodes; the same command again resumes with nothing left to run."""
import json
import os
from pathlib import Path

import pytest

from drill_bag import export

from drill_studies import sweep

pytestmark = [pytest.mark.dds, pytest.mark.slow]
SCENARIO = str(Path(__file__).resolve().parent / "scenarios" / "sweep_short.yaml")
NO_BHP_NOISE = "plant.measurement_noise.bhp_pa=0"


def _run_dirs(output: Path) -> list[Path]:
    return sorted(p.parent for p in output.glob("*/*/summary.json"))


def _ran_elsewhere(run_dir: Path) -> bool:
    """The run directory's name ends with the pid of the process that ran the graph."""
    return int(run_dir.name.rsplit("-", 1)[1]) != os.getpid()


def test_a_sweep_on_the_local_pool_resumes_and_carries_its_override(tmp_path):
    said = []
    assert sweep.sweep(SCENARIO, 2, 7, sets=[NO_BHP_NOISE], workers=2, output=tmp_path,
                       say=said.append) == 0
    index = json.loads((tmp_path / sweep.INDEX_FILE).read_text())
    assert [(r["controller"], r["seed"], r["ok"]) for r in index["runs"]] == [
        ("baseline", 7, True), ("baseline", 8, True)]
    runs = _run_dirs(tmp_path)
    assert len(runs) == 2 and all(_ran_elsewhere(r) for r in runs)
    assert {json.loads((r / "launch.json").read_text())["seed"] for r in runs} == {7, 8}
    rmse = [r["summary"]["bhp_rmse_pa"] for r in index["runs"]]
    assert rmse[0] != rmse[1]                                   # two seeds, two trips
    assert "| BHP RMSE [bar] |" in (tmp_path / sweep.TABLE_FILE).read_text()
    for run in runs:       # no BHP gauge noise: the plant read the override
        tables = export.topic_tables(next(run.glob("*.mcap")), ["/rig/measurement", "/rig/truth"])
        measured = dict(zip(tables["/rig/measurement"].column("stamp_ns").to_pylist(),
                            tables["/rig/measurement"].column("bhp_pa").to_pylist()))
        truth = dict(zip(tables["/rig/truth"].column("stamp_ns").to_pylist(),
                         tables["/rig/truth"].column("bhp_pa").to_pylist()))
        assert len(measured) == 201 and measured == {t: truth[t] for t in measured}

    said.clear()
    assert sweep.sweep(SCENARIO, 2, 7, sets=[NO_BHP_NOISE], workers=2, output=tmp_path,
                       say=said.append) == 0
    assert "2 done before, 0 to run" in said[0] and _run_dirs(tmp_path) == runs


def test_a_sweep_on_a_dask_cluster_runs_the_graph_on_its_worker(tmp_path):
    from distributed import LocalCluster
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        assert sweep.sweep(SCENARIO, 1, 11, controllers=["baseline"],
                           cluster=cluster.scheduler_address, output=tmp_path,
                           say=lambda text: None) == 0
    [run] = _run_dirs(tmp_path)
    assert _ran_elsewhere(run) and run.parent.name == "baseline-seed11"
    index = json.loads((tmp_path / sweep.INDEX_FILE).read_text())
    assert index["runs"][0]["ok"] and index["runs"][0]["run_dir"] == str(run)
