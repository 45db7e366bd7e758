"""rig export without DDS: a recording written with mcap_io's writer, exported to CSV and
Parquet, read back with pyarrow and compared value by value (NaN, inf and every stamp
included) with the messages written; unit-named columns; the wide table's hold."""
import math

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import pytest
from drill_msgs.msg import ActuatorFrame, NodeStatus, PlantTruth, RigMeasurement
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from drill_bag import export, mcap_io

from drill_rig import cli
from drill_bag.msg_columns import comment_unit, names_unit, unit_token

NS = 1_000_000_000
LOG_DELAY_NS = 3_000_000          # the recorder logs each message a little after its stamp


def stamped(msg, stamp_ns: int):
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, NS)
    return msg


def measurements():
    values = [1.0e5, math.nan, math.inf, -math.inf, 6.85e7 + 0.1]
    return [stamped(RigMeasurement(bhp_pa=v, choke_dp_pa=2.0e6 + i, block_position_m=0.25 * i,
                                   string_flow_m3s=0.016667 if i % 2 else math.nan,
                                   string_flow_valid=bool(i % 2), return_flow_m3s=1e-300,
                                   pit_volume_m3=40.0 - i, bpp_flow_m3s=0.0),
                    k * NS // 10 + 1_000_000_007)
            for k, (i, v) in enumerate(enumerate(values))]


def truths():
    return [stamped(PlantTruth(annulus_pressure_pa=[1.0e6 * (j + i) for j in range(4)],
                               choke_opening=0.5 + 0.1 * i, ecd_kgm3=1500.0,
                               choke_capacity_factor=math.nan if i == 1 else 1.0),
                    1_000_000_007 + i * NS // 10) for i in range(3)]


def frames():
    return [stamped(ActuatorFrame(actuator="drawworks", unit="m", command=0.1 * i,
                                  output=[0.01 * j + i for j in range(3)], sample_period_s=0.01,
                                  reference=math.nan, fault="" if i else "stuck"),
                    1_000_000_007 + i * NS // 10) for i in range(2)]


def statuses():    # arrays of different lengths: the shorter message has nulls after its end
    return [stamped(NodeStatus(node="plant", keys=["a_s", "b_pa"][:n], values=[0.5, math.inf][:n],
                               error_count=2**40 + n, healthy=n == 2, rate_hz=10.0),
                    1_000_000_007 + i * NS // 10) for i, n in enumerate((2, 1))]


def notes():
    return [String(data=text) for text in ("", "a, \"quoted\" note", "1")]


TOPICS = {"/rig/measurement": ("drill_msgs/msg/RigMeasurement", measurements),
          "/rig/truth": ("drill_msgs/msg/PlantTruth", truths),
          "/actuators/drawworks/frame": ("drill_msgs/msg/ActuatorFrame", frames),
          "/plant/status": ("drill_msgs/msg/NodeStatus", statuses),
          "/note": ("std_msgs/msg/String", notes)}
# Columns whose field name lacks the unit of its comment; the rest keep the field name.
RENAMED = {"choke_opening": "choke_opening_1", "choke_capacity_factor": "choke_capacity_factor_1",
           "command": "command_m", "output": "output_m"}


def stamp_of(msg, log_ns):
    return msg.header.stamp.sec * NS + msg.header.stamp.nanosec if hasattr(msg, "header") \
        else log_ns


@pytest.fixture
def run_dir(tmp_path):
    """A run directory holding a small recording; the messages written, per topic."""
    run = tmp_path / "run"
    run.mkdir()
    written = {}
    with mcap_io.McapWriter(run / "run.mcap") as writer:
        for topic, (type_name, make) in TOPICS.items():
            writer.add_topic(topic, type_name)
            written[topic] = []
            for i, msg in enumerate(make()):
                log_ns = stamp_of(msg, 5 * NS + i) + LOG_DELAY_NS
                writer.write(topic, serialize_message(msg), log_ns)
                written[topic].append((msg, log_ns))
    return run, written


def csv_types(schema):
    """The Parquet file's column types for reading its CSV twin (whose time_utc is text)."""
    return pa.schema([pa.field("time_utc", pa.string()) if f.name == "time_utc" else f
                      for f in schema])


def read_back(path, fmt, schema=None):
    if fmt == "parquet":
        return pq.read_table(path)
    options = pa_csv.ConvertOptions(null_values=[""], strings_can_be_null=True,
                                    quoted_strings_can_be_null=False,
                                    column_types=schema)
    return pa_csv.read_csv(path, convert_options=options)


def leaves(msg):
    """(column, value) of every field but the header, by the documented naming rule."""
    for name in msg.get_fields_and_field_types():
        if name == "header":
            continue
        column, value = RENAMED.get(name, name), getattr(msg, name)
        if isinstance(value, (list, tuple, np.ndarray)) or hasattr(value, "typecode"):
            for i, element in enumerate(value):
                yield f"{column}[{i}]", element
        else:
            yield column, value


def same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


@pytest.mark.parametrize("fmt", export.TABLE_FORMATS)
def test_every_value_and_stamp_survives_the_round_trip(run_dir, fmt):
    run, written = run_dir
    paths = {f: export.export(run, f) for f in export.TABLE_FORMATS}[fmt]
    assert sorted(p.name for p in paths) == sorted(f"{export.file_stem(t)}.{fmt}" for t in TOPICS)
    assert all(p.parent == run / "export" for p in paths)
    for topic, messages in written.items():
        path = run / "export" / f"{export.file_stem(topic)}.{fmt}"
        types = csv_types(pq.read_table(path.with_suffix(".parquet")).schema)  # CSV has none
        table = read_back(path, fmt, types)
        rows = table.to_pylist()
        assert len(rows) == len(messages), topic
        for row, (msg, log_ns) in zip(rows, messages):
            stamp = stamp_of(msg, log_ns)
            assert row["stamp_ns"] == stamp and row["log_time_ns"] == log_ns
            seconds, ns = divmod(stamp, NS)
            utc = np.datetime64(seconds, "s").item().strftime("%Y-%m-%dT%H:%M:%S")
            if fmt == "csv":
                assert row["time_utc"] == f"{utc}.{ns // 1_000_000:03d}Z"
            else:                                   # the stamp exactly, as a UTC timestamp
                assert row["time_utc"].value == stamp and str(row["time_utc"].tz) == "UTC"
            expected = dict(leaves(msg))
            for column, value in expected.items():
                assert same(row[column], value), (topic, column, row[column], value)
            extra = {c for c in row if c not in expected and c not in export.TIME_COLUMNS}
            assert all(row[c] is None for c in extra), (topic, extra)


def test_csv_reads_back_like_the_parquet_file(run_dir):
    run, _ = run_dir
    export.export(run, "parquet")
    export.export(run, "csv")
    for topic in TOPICS:
        parquet = pq.read_table(run / "export" / f"{export.file_stem(topic)}.parquet")
        csv = read_back(run / "export" / f"{export.file_stem(topic)}.csv", "csv",
                        csv_types(parquet.schema))
        assert csv.column_names == parquet.column_names
        for a, b in zip(csv.to_pylist(), parquet.to_pylist()):
            assert all(same(a[k], b[k]) for k in a if k != "time_utc"), topic
    text = (run / "export" / "rig.measurement.csv").read_text().splitlines()
    assert ",nan," in text[2] and ",inf," in text[3] and ",-inf," in text[4]


def test_unit_naming_follows_the_msg_comments():
    assert comment_unit("bottom-hole pressure p_n, gauge [Pa]") == "Pa"
    assert comment_unit("output at t_k + i*dt, i = 0..N-1 [unit]") == "unit"
    assert comment_unit("drawworks u_r [m], choke flow ref [m^3/s]") == ""
    assert comment_unit("name of the node") == ""
    assert names_unit("string_flow_m3s", "m^3/s") and names_unit("velocity_mps", "m/s")
    assert names_unit("top_drive_speed_rad_s", "rad/s") and names_unit("tob_nm", "N m")
    assert not names_unit("choke_opening", "1") and not names_unit("bhp_pa", "m")
    assert (unit_token("m^3/s"), unit_token("m/s"), unit_token("1")) == ("m3s", "mps", "1")


def test_the_wide_table_holds_each_channel_at_the_grid(run_dir):
    run, written = run_dir
    [path] = export.export(run, "parquet", topics=["/rig/measurement", "/rig/truth"],
                           wide_hz=20.0, output=run / "wide")
    assert path == run / "wide" / "wide-20hz.parquet"
    table = pq.read_table(path).to_pylist()
    measured = [(stamp_of(m, log), m) for m, log in written["/rig/measurement"]]
    truth = [(stamp_of(m, log), m) for m, log in written["/rig/truth"]]
    first = measured[0][0]
    assert [r["stamp_ns"] for r in table] == [first + k * NS // 20 for k in range(len(table))]
    assert table[-1]["stamp_ns"] <= measured[-1][0] < table[-1]["stamp_ns"] + NS // 20
    for row in table:
        latest = [m for s, m in measured if s <= row["stamp_ns"]][-1]
        assert same(row["rig.measurement.bhp_pa"], latest.bhp_pa)
        held = [(s, m) for s, m in truth if s <= row["stamp_ns"]]
        assert row["rig.truth.stamp_ns"] == held[-1][0]
        assert row["rig.truth.choke_opening_1"] == held[-1][1].choke_opening
    assert "rig.measurement.log_time_ns" not in table[0]


def test_bad_run_directory_topic_or_rate_is_refused(run_dir, tmp_path, capsys):
    run, _ = run_dir
    with pytest.raises(export.ExportError, match="no such directory"):
        export.export(tmp_path / "missing")
    with pytest.raises(export.ExportError, match="found none"):
        export.export(tmp_path)
    with pytest.raises(export.ExportError, match=r"/rig/nothing not recorded; recorded: "):
        export.export(run, topics=["/rig/nothing"])
    with pytest.raises(export.ExportError, match="must be a positive rate"):
        export.export(run, wide_hz=0.0)
    assert cli.main(["export", str(run), "--topics", "/rig/nothing"]) == 2
    assert "/rig/nothing not recorded" in capsys.readouterr().err
    assert not (run / "export").exists()


def test_rig_export_writes_the_chosen_topics(run_dir, capsys):
    run, _ = run_dir
    assert cli.main(["export", str(run), "--format", "parquet", "--topics", "/note"]) == 0
    assert [p.name for p in (run / "export").iterdir()] == ["note.parquet"]
    assert pq.read_table(run / "export" / "note.parquet").column("data").to_pylist() == \
        ["", "a, \"quoted\" note", "1"]
    assert "note.parquet" in capsys.readouterr().out
    assert pq.read_table(run / "export" / "note.parquet").schema.field("time_utc").type == \
        pa.timestamp("ns", tz="UTC")


def test_parquet_columns_carry_their_units(run_dir):
    run, _ = run_dir
    export.export(run, "parquet")
    export.export(run, "parquet", topics=["/rig/measurement"], wide_hz=20.0, output=run / "w")

    def unit(path, column):
        return (pq.read_schema(path).field(column).metadata or {}).get(b"unit", b"").decode()
    measurement = run / "export" / "rig.measurement.parquet"
    assert unit(measurement, "bhp_pa") == "Pa" and unit(measurement, "string_flow_m3s") == "m^3/s"
    assert unit(measurement, "stamp_ns") == "ns" and unit(measurement, "string_flow_valid") == ""
    frames = run / "export" / "actuators.drawworks.frame.parquet"    # unit from the message's
    assert unit(frames, "output_m[0]") == "m" and unit(frames, "sample_period_s") == "s"
    wide = run / "w" / "wide-20hz.parquet"
    assert unit(wide, "rig.measurement.bhp_pa") == "Pa" and unit(wide, "stamp_ns") == "ns"
