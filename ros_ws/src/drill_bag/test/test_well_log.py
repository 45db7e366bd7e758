"""The well log exports without DDS: a small recording written with mcap_io's writer into
a run directory (its well.yaml the reference well's), exported to LAS and WITSML and read
back with readers this project did not write (lasio; the Energistics WITSML 2.1 types'
strict parser), each channel compared with what the messages say, worked out here by
hand: the bit depth from the string's section lengths in well.yaml, kPa and L/min from
Pa and m^3/s, the frame output in force at each stamp."""
import json
import math
import shutil

import lasio
import numpy as np
import pytest
from drill_msgs.msg import ActuatorFrame, RigMeasurement
from energyml.eml.v2_3.commonv2 import DataIndexKind
from energyml.witsml.v2_1 import witsmlv2 as witsml
from rclpy.serialization import serialize_message
from xsdata.exceptions import ParserError

from drill_bag import export, mcap_io, witsml_export
from drill_bag.well_log import BY_MNEMONIC, LiveRig
from drill_core.config import Well, load_section
from drill_core.rig_root import rig_root

NS = 1_000_000_000
STRING_LENGTH_M = 3296.7 + 251.1 + 60.0     # well.yaml: drill pipe, collars, BHA
FRAME_STEP_S = 0.01
SAMPLES = 6                                  # 0.1 s apart


def stamped(msg, stamp_ns):
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, NS)
    return msg


def measurement(k):
    pumping = k != 3                        # sample 3: the pump is off, no flow-in reading
    return stamped(RigMeasurement(
        block_position_m=0.5 * k, choke_dp_pa=2.0e6 + 1.0e4 * k, bhp_pa=6.85e7 - 1.0e3 * k,
        string_flow_m3s=0.0166 if pumping else math.nan, string_flow_valid=pumping,
        return_flow_m3s=0.0170, pit_volume_m3=40.0 + 0.01 * k, bpp_flow_m3s=0.0002,
        hook_load_n=1.25e6 - 1.0e3 * k),
        k * NS // 10)


def frame(actuator, unit, k, base):
    """The frame stamped at sample k: ten outputs 0.01 s apart."""
    return stamped(ActuatorFrame(actuator=actuator, unit=unit, command=base,
                                 output=[base + k + 0.1 * i for i in range(10)],
                                 sample_period_s=FRAME_STEP_S, reference=base),
                   k * NS // 10)


@pytest.fixture
def run(tmp_path):
    """A run directory: config/well.yaml, launch.json and a recording whose frames are
    logged after the sample they start at (as the graph's order has them); frame 4 of
    the choke is missing, so sample 4 reads frame 3's output 0.1 s on."""
    run = tmp_path / "case2-20261204-000000-1"
    (run / "config").mkdir(parents=True)
    shutil.copy(rig_root() / "config" / "well.yaml", run / "config" / "well.yaml")
    (run / "launch.json").write_text(json.dumps({"scenario": "/x/case2.yaml", "controller":
                                                 "nmpc", "seed": 7, "mismatch": "yield_high",
                                                 "mode": "fast"}))
    with mcap_io.McapWriter(run / "case2.mcap") as writer:
        for topic, type_name in (("/rig/measurement", "drill_msgs/msg/RigMeasurement"),
                                 ("/actuators/mud_pump/frame", "drill_msgs/msg/ActuatorFrame"),
                                 ("/actuators/choke/frame", "drill_msgs/msg/ActuatorFrame")):
            writer.add_topic(topic, type_name)
        for k in range(SAMPLES):
            t = k * NS // 10
            writer.write("/rig/measurement", serialize_message(measurement(k)), t + 1000)
            writer.write("/actuators/mud_pump/frame",
                         serialize_message(frame("mud_pump", "Pa", k, 1.0e7)), t + 2000)
            if k != 4:
                writer.write("/actuators/choke/frame",
                             serialize_message(frame("choke", "1", k, 0.2)), t + 3000)
    return run


def expected(k):
    """mnemonic -> the channel's value at sample k, by hand."""
    m = measurement(k)
    choke = 0.2 + 3 + 0.1 * 9 if k == 4 else 0.2 + k     # frame 3, clipped at its last
    flow_in = m.string_flow_m3s * 60000.0 if m.string_flow_valid else math.nan
    return {"DBTM": STRING_LENGTH_M - m.block_position_m, "BPOS": m.block_position_m,
            "HKLA": 1250.0 - k, "SPPA": (1.0e7 + k) / 1000.0, "CHKP": m.choke_dp_pa / 1000.0,
            "TVA": m.pit_volume_m3, "TVCA": 0.01 * k, "MFOA": 0.0170 * 60000.0,
            "MFIA": flow_in, "BHP": m.bhp_pa / 1000.0, "BPPF": 0.0002 * 60000.0,
            "DFLO": (0.0170 - 0.0166 - 0.0002) * 60000.0 if m.string_flow_valid else math.nan,
            "CHKO": 100.0 * choke}


UNITS = {"DBTM": "m", "BPOS": "m", "HKLA": "kN", "SPPA": "kPa", "CHKP": "kPa", "TVA": "m3",
         "TVCA": "m3", "MFOA": "L/min", "MFIA": "L/min", "BHP": "kPa", "BPPF": "L/min",
         "DFLO": "L/min", "CHKO": "%"}


def close(a, b):
    return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-9)


def test_lasio_reads_every_channel_with_its_unit_and_value(run):
    [path] = export.export(run, "las")
    assert path == run / "export" / f"{run.name}.las"
    las = lasio.read(path)
    assert las.version["VERS"].value == 2.0
    assert [c.mnemonic for c in las.curves] == ["TIME", *UNITS]
    assert {c.mnemonic: c.unit for c in las.curves} == {"TIME": "s", **UNITS}
    assert np.allclose(las["TIME"], [0.1 * k for k in range(SAMPLES)])
    for k in range(SAMPLES):
        for mnemonic, value in expected(k).items():
            assert close(las[mnemonic][k], value), (k, mnemonic, las[mnemonic][k], value)
    params = {p.mnemonic: p.value for p in las.params}
    assert (params["SCEN"], params["CTRL"], params["SEED"], params["MISM"]) == \
        ("case2", "nmpc", 7, "yield_high")
    assert math.isclose(params["BDEP"], STRING_LENGTH_M)
    assert las.well["UWI"].value == run.name


def test_the_witsml_log_parses_strictly_with_its_channels_and_data(run):
    paths = export.export(run, "witsml")
    assert [p.name for p in paths] == ["well.xml", "wellbore.xml", "log.xml"]
    well = witsml_export.parse(paths[0].read_text(), witsml.Well)
    wellbore = witsml_export.parse(paths[1].read_text(), witsml.Wellbore)
    log = witsml_export.parse(paths[2].read_text(), witsml.Log)
    assert wellbore.well.uuid == well.uuid and log.wellbore.uuid == wellbore.uuid
    [channel_set] = log.channel_set
    [index] = channel_set.index
    assert (index.index_kind, index.uom.value, index.mnemonic) == \
        (DataIndexKind.ELAPSED_TIME, "s", "TIME")
    assert {c.mnemonic: c.uom.value for c in channel_set.channel} == UNITS
    rows = json.loads(channel_set.data.data)
    assert len(rows) == SAMPLES
    for k, (indices, values) in enumerate(rows):
        assert math.isclose(indices[0], 0.1 * k)
        for mnemonic, got in zip(UNITS, values):
            want = expected(k)[mnemonic]
            assert (got is None and math.isnan(want)) or close(got, want), (k, mnemonic)
    again = export.export(run, "witsml", output=run / "again")
    assert witsml_export.parse(again[2].read_text(), witsml.Log).uuid == log.uuid


def test_the_strict_parser_refuses_what_the_schema_does_not_have(run):
    xml = export.export(run, "witsml")[2].read_text()
    with pytest.raises(ParserError):
        witsml_export.parse(xml.replace("<witsml:RunNumber>", "<witsml:RunNumbr>")
                            .replace("</witsml:RunNumber>", "</witsml:RunNumbr>"), witsml.Log)
    with pytest.raises(ParserError):
        witsml_export.parse(xml.replace("<eml:ActiveStatus>inactive<",
                                        "<eml:ActiveStatus>sleeping<", 1), witsml.Log)


def test_a_well_log_takes_no_topic_choice_and_needs_the_run_config(run):
    with pytest.raises(export.ExportError, match="--topics and --wide are for csv and parquet"):
        export.export(run, "las", wide_hz=1.0)
    shutil.rmtree(run / "config")
    with pytest.raises(export.ExportError, match="well.yaml"):
        export.export(run, "witsml")
    assert not (run / "export").exists()          # refused before anything is written


def test_a_live_run_gives_the_newest_sample_with_its_frames_and_the_first_pit():
    live = LiveRig(load_section(Well, rig_root() / "config" / "well.yaml"))
    assert live.snapshot() is None                      # nothing before the first sample
    live.on_measurement(measurement(0))
    live.on_frame("mud_pump", frame("mud_pump", "Pa", 0, 1.0e7))
    live.on_measurement(measurement(2))
    snapshot = live.snapshot()
    assert snapshot.stamp_ns == 2 * NS // 10 and snapshot.measurement.block_position_m == 1.0
    for mnemonic in ("DBTM", "TVCA"):
        assert close(BY_MNEMONIC[mnemonic].value(snapshot), expected(2)[mnemonic]), mnemonic
    # frame 0 in force 0.2 s on: its output clipped at the last of its ten samples
    assert close(BY_MNEMONIC["SPPA"].value(snapshot), (1.0e7 + 0.9) / 1000.0)
