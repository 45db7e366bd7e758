"""Over DDS, a plant that is not the model: Case 2's short trip with the plant's mud and
choke off the mud report (config/mismatch.yaml thick_report). Only the plant's side of
the graph is given the mismatch (the live subscribers of the truth topic, the parameters
each process was launched with, the scenario file the others read); the run records its
plant; the NMPC (with the estimator's density offset) raises no false alarm and holds BHP
better than the PI baseline on the same plant."""
import json
import threading

import pytest
import yaml
from rig_testing import held_test_domain, spinning_node

from drill_bag import mcap_io

from drill_rig import cli
from drill_core.mismatch import read_truth_file, resolve
from drill_ros import graph as graph_decl
from drill_ros import topics

pytestmark = [pytest.mark.dds, pytest.mark.slow]
SCENARIO = cli.ROOT / "config" / "scenarios" / "short_trip.yaml"
MISMATCH = "thick_report"
TRUTH_SIDE = {n.name for n in graph_decl.NODES if n.truth_side}
UNKNOWN = "_NODE_NAME_UNKNOWN_"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The short trip on the mismatched plant under the NMPC (the truth topic's live
    subscribers sampled while it runs) and under the PI baseline."""
    out = {}
    domain = held_test_domain()
    for controller in ("nmpc", "baseline"):
        seen: set[str] = set()
        done = threading.Event()
        result = {}

        def launch():
            result["run"] = cli.run_scenario(
                SCENARIO, runs_dir=tmp_path_factory.mktemp(controller), domain_id=domain,
                timeout_s=300, quiet=True, controller=controller, mismatch=MISMATCH)
            done.set()

        with pytest.MonkeyPatch.context() as monkeypatch, \
                spinning_node(domain, "truth_watch", monkeypatch) as node:
            thread = threading.Thread(target=launch)
            thread.start()
            while not done.wait(0.05):
                # an endpoint discovered before its node's name reads _NODE_NAME_UNKNOWN_
                # (rmw); it is named once its participant's node list arrives
                seen |= {info.node_name for info in
                         node.get_subscriptions_info_by_topic(topics.TRUTH)} - {UNKNOWN}
            thread.join()
        code, run_dir = result["run"]
        assert code == 0, (run_dir / "launch.json").read_text()
        out[controller] = (run_dir, seen)
    return out


def test_only_the_plants_side_is_given_the_mismatch(runs):
    for controller, (run_dir, truth_subscribers) in runs.items():
        assert truth_subscribers, "the truth topic's subscribers were never seen"
        assert truth_subscribers <= TRUTH_SIDE, truth_subscribers
        launched = json.loads((run_dir / "launch.json").read_text())["parameters"]
        assert controller in launched and "estimator" in launched and "protection" in launched
        for name, params in launched.items():
            assert ("truth" in params) == (name in TRUTH_SIDE), (name, params)
            scenario = yaml.safe_load(open(params["scenario"]))
            assert "truth" not in scenario, name
        name, mismatch = read_truth_file(launched["plant"]["truth"])
        assert (name, mismatch) == resolve(MISMATCH, cli.ROOT / "config")


def test_the_recording_says_what_its_plant_was(runs):
    run_dir, _ = runs["nmpc"]
    recorded = mcap_io.read_metadata(next(run_dir.glob("*.mcap")), mcap_io.TRUTH_METADATA)
    assert json.loads(recorded["truth"])["name"] == MISMATCH
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["plant_mismatch"]["name"] == MISMATCH
    assert summary["plant_mismatch"]["mismatch"] == resolve(MISMATCH, cli.ROOT / "config")[1].changes()


def test_no_false_alarm_and_the_nmpc_beats_the_pi_baseline(runs):
    figures = {}
    for controller, (run_dir, _) in runs.items():
        summary = json.loads((run_dir / "summary.json").read_text())
        for kind in ("kick", "losses"):
            assert summary["detection"][kind]["false_alarms"] == 0, (controller, kind)
        figures[controller] = summary
    assert figures["nmpc"]["bhp_rmse_settled_pa"] < figures["baseline"]["bhp_rmse_settled_pa"]
