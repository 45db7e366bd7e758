"""Integration over DDS: a kick swabbed in on a multi-stand trip
(test/scenarios/trip_out_swabbed_kick_2.yaml, config/scenarios/trip_out_swabbed_kick.yaml
cut to two stands, its zone a bar nearer the reference so that two stands swab in more than
the limit: pulled under the PI baseline into a zone whose pore pressure is 3 bar under the
BHP reference, the trip sheet's alarm limit 0.1 m^3). The well flows; the
protection's live trip sheet raises trip_tank_gain from the trip tank against the steel
tripped; the report's sheet, made afterwards from the same recording, reads each
measurement with the same floor command and books the same alarm and the influx the truth
recorded."""
import json
from pathlib import Path

import pytest

from drill_bag import mcap_io
from drill_rig import cli
from drill_ros import topics
from drill_ros.stamps import to_ns

pytestmark = [pytest.mark.dds, pytest.mark.slow]
SCENARIO = Path(__file__).resolve().parent / "scenarios" / "trip_out_swabbed_kick_2.yaml"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    code, run_dir = cli.run_scenario(SCENARIO, runs_dir=tmp_path_factory.mktemp("swabbed_kick"),
                                     timeout_s=600, quiet=True)
    assert code == 0, (run_dir / "launch.json").read_text()
    mcap = next(run_dir.glob("*.mcap"))
    live = [(to_ns(msg.header.stamp), msg.code) for _, msg in
            mcap_io.decoded_messages(mcap, [topics.PROTECTION_EVENTS])
            if msg.code.startswith("trip_tank")]
    influx_m3 = max(msg.influx_volume_m3 for _, msg in
                    mcap_io.decoded_messages(mcap, [topics.TRUTH]))
    return live, influx_m3, json.loads((run_dir / "summary.json").read_text())


def test_the_live_sheet_alarms_on_the_swabbed_influx_and_the_report_books_the_same(run):
    live, influx_m3, summary = run
    assert influx_m3 > 0.1                                   # the well flowed past the limit
    assert [code for _, code in live] == ["trip_tank_gain"]  # raised once, live
    assert summary["trip_sheet_alarms"] == ["trip_tank_gain"]
    # the stand whose end raised it: the report's running gain first past the limit there
    raised_s = live[0][0] * 1e-9
    row = next(r for r in summary["trip_sheet"] if r["cumulative_gain_m3"] > 0.1)
    assert row["end_s"] == pytest.approx(raised_s, abs=0.2)
    # the sheet's gain is the influx, within what it books on a trip with none: the mud the
    # pressure at each stand's slips compresses or frees (trip_out: up to 20 L a stand)
    assert summary["trip_tank_discrepancy_m3"] == pytest.approx(influx_m3, abs=0.03)
