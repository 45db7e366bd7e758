"""``rig export``: a recorded run as tables (CSV or Parquet), one per topic or one wide
table resampled at a chosen rate, for analysis outside the rig.

Plain Python (no rclpy): the messages are read and decoded with the definitions the MCAP
file carries (drill_bag.mcap_io), so a recording made before a message changed
exports with its own fields. Every table starts with ``time_utc`` (ISO 8601, UTC,
milliseconds, ``Z``; the message's header stamp, the log time for a message without a
header), ``stamp_ns`` (that stamp exactly, ns since the epoch) and ``log_time_ns`` (when
the recorder logged it); then one column per field, named with its SI unit
(drill_bag.msg_columns). In fast mode the stamps are simulated time from the start
of the scenario (0 s = 1970-01-01T00:00:00.000Z). Non-finite values stay: NaN, inf and
-inf are ``nan``, ``inf`` and ``-inf`` in CSV; an array element a message does not have is
empty (null). The wide table holds, at every point of a grid at the chosen rate from
the first stamp to the last, the latest sample of each channel at or before it
(zero-order hold; null before a topic's first), its columns prefixed by the topic
(``rig.measurement.bhp_pa``, with ``rig.measurement.stamp_ns`` the held sample's stamp).
In Parquet ``time_utc`` is a ``timestamp[ns, UTC]`` (the stamp exactly) and every column
with a unit carries it in its field metadata (``unit``: ``Pa``, ``m^3/s``, ``ns``).
docs/exports-and-sweeps.md has the details.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from drill_bag import las_export, mcap_io, well_log, witsml_export
from drill_bag.msg_columns import Layout, names_unit, unit_token

TABLE_FORMATS = ("csv", "parquet")
LOG_FORMATS = ("las", "witsml")
FORMATS = TABLE_FORMATS + LOG_FORMATS
EXPORT_DIR = "export"
TIME_COLUMNS = ("time_utc", "stamp_ns", "log_time_ns")
MAX_WIDE_ROWS = 10_000_000
KINDS = {"float": pa.float64(), "int": pa.int64(), "uint64": pa.uint64(), "bool": pa.bool_(),
         "string": pa.string()}


class ExportError(ValueError):
    """A run directory, topic or option the export cannot use; the message says why."""


def run_mcap(run_dir: Path) -> Path:
    """The one MCAP file of a run directory."""
    if not run_dir.is_dir():
        raise ExportError(f"{run_dir}: not a run directory (no such directory)")
    files = sorted(run_dir.glob("*.mcap"))
    if len(files) != 1:
        found = ", ".join(f.name for f in files) or "none"
        raise ExportError(f"{run_dir}: a run directory holds one .mcap recording; found {found}")
    return files[0]


def file_stem(topic: str) -> str:
    """File name (and wide-table prefix) of a topic: '/rig/measurement' -> 'rig.measurement'."""
    return topic.strip("/").replace("/", ".")


def iso_utc(stamps_ns: np.ndarray) -> list[str]:
    """ISO 8601 UTC text with milliseconds (truncated) and 'Z' of ns since the epoch."""
    ms = np.asarray(stamps_ns, dtype=np.int64).astype("datetime64[ns]").astype("datetime64[ms]")
    return [f"{text}Z" for text in np.datetime_as_string(ms, unit="ms")]


def select_topics(mcap: Path, topics) -> list[str]:
    """The topics to export (all recorded ones by default); an unknown one is an error."""
    recorded = mcap_io.topics(mcap)
    if not topics:
        return sorted(recorded)
    unknown = [t for t in topics if t not in recorded]
    if unknown:
        raise ExportError(f"{mcap}: topic(s) {', '.join(unknown)} not recorded; recorded: "
                          f"{', '.join(sorted(recorded))}")
    return list(dict.fromkeys(topics))


class _TopicRows:
    """The decoded messages of one topic, as rows of its columns."""

    def __init__(self, layout: Layout):
        self.layout = layout
        self.rows: list[dict] = []
        self.stamps_ns: list[int] = []
        self.log_times_ns: list[int] = []

    def add(self, recorded: mcap_io.RecordedMessage, message) -> None:
        stamp = recorded.log_time_ns
        if self.layout.has_header:
            s = message.header.stamp
            stamp = s.sec * mcap_io.NS_PER_S + s.nanosec
        self.rows.append(self.layout.row(message))
        self.stamps_ns.append(stamp)
        self.log_times_ns.append(recorded.log_time_ns)

    def table(self) -> pa.Table:
        columns = list(dict.fromkeys(c for row in self.rows for c in row))
        stamps = np.asarray(self.stamps_ns, dtype=np.int64)
        data = {"time_utc": pa.array(iso_utc(stamps), pa.string()),
                "stamp_ns": pa.array(stamps, pa.int64()),
                "log_time_ns": pa.array(self.log_times_ns, pa.int64())}
        for column in columns:
            data[column] = pa.array([row.get(column) for row in self.rows],
                                    KINDS[self.layout.kind(column)])
        units = {"stamp_ns": "ns", "log_time_ns": "ns",
                 **{c: self.layout.unit(c) for c in columns}}
        return _with_message_unit(_with_units(pa.table(data), units),
                                  self.layout.placeholder_columns)


def _with_units(table: pa.Table, units: dict[str, str]) -> pa.Table:
    """Each column's SI unit (``units``: column -> unit, '' none) in its field metadata
    (``unit``), which Parquet keeps."""
    fields = [field.with_metadata({"unit": units[field.name]})
              if units.get(field.name) else field for field in table.schema]
    return table.cast(pa.schema(fields))


def _with_message_unit(table: pa.Table, placeholders: frozenset[str]) -> pa.Table:
    """Columns whose unit is in the message's ``unit`` field get it appended, when every
    message of the topic gives the same one."""
    if "unit" not in table.column_names or not placeholders:
        return table
    units = set(table.column("unit").to_pylist())
    if len(units) != 1 or not next(iter(units)):
        return table
    unit = units.pop()

    def renamed(name: str) -> str:
        base, bracket, index = name.partition("[")
        if base not in placeholders or names_unit(base, unit):
            return name
        return f"{base}_{unit_token(unit)}{bracket}{index}"
    placeholder = {name for name in table.column_names if name.partition("[")[0] in placeholders}
    table = _with_units(table, {name: unit for name in placeholder})
    return table.rename_columns([renamed(n) for n in table.column_names])


def topic_tables(mcap: Path, topics=None) -> dict[str, pa.Table]:
    """One table per topic (recorded order), columns as the module docstring says."""
    selected = select_topics(mcap, topics)
    by_topic: dict[str, _TopicRows] = {}
    for recorded in mcap_io.read_messages(mcap, selected):
        rows = by_topic.get(recorded.topic)
        if rows is None:
            rows = by_topic[recorded.topic] = _TopicRows(
                Layout.of(recorded.type_name, recorded.definition))
        rows.add(recorded, mcap_io.decode(recorded))
    return {topic: by_topic[topic].table() for topic in selected if topic in by_topic}


def wide_table(tables: dict[str, pa.Table], rate_hz: float) -> pa.Table:
    """The topics' channels on one time grid at ``rate_hz`` (zero-order hold)."""
    if not tables:
        raise ExportError("--wide: no messages on the topics chosen")
    period_ns = max(int(round(mcap_io.NS_PER_S / rate_hz)), 1)
    first = min(int(t.column("stamp_ns").to_numpy().min()) for t in tables.values())
    last = max(int(t.column("stamp_ns").to_numpy().max()) for t in tables.values())
    rows = (last - first) // period_ns + 1
    if rows > MAX_WIDE_ROWS:
        raise ExportError(f"--wide: value {rate_hz:g} Hz makes {rows} rows over the run's "
                          f"{(last - first) / mcap_io.NS_PER_S:g} s; at most {MAX_WIDE_ROWS}")
    grid = first + period_ns * np.arange(rows, dtype=np.int64)
    data = {"time_utc": pa.array(iso_utc(grid), pa.string()),
            "stamp_ns": pa.array(grid, pa.int64())}
    units = {"stamp_ns": "ns"}
    for topic, table in tables.items():
        stamps = table.column("stamp_ns").to_numpy()
        order = np.argsort(stamps, kind="stable")
        held = np.searchsorted(stamps[order], grid, side="right") - 1
        index = pa.array(order[np.maximum(held, 0)], pa.int64(), mask=held < 0)
        for field in table.schema:
            if field.name not in ("time_utc", "log_time_ns"):
                column = f"{file_stem(topic)}.{field.name}"
                data[column] = table.column(field.name).take(index)
                units[column] = (field.metadata or {}).get(b"unit", b"").decode()
    return _with_units(pa.table(data), units)


def write_table(table: pa.Table, path: Path, fmt: str) -> Path:
    """Write one table as CSV or Parquet (there ``time_utc`` is a timestamp[ns, UTC], the
    stamp exactly)."""
    if fmt == "csv":
        pa_csv.write_csv(table, path)
    else:
        utc = table.column("stamp_ns").cast(pa.timestamp("ns", tz="UTC"))
        table = table.set_column(table.column_names.index("time_utc"), "time_utc", utc)
        pq.write_table(table, path)
    return path


def export(run_dir: Path, fmt: str = "csv", topics=None, wide_hz: float | None = None,
           output: Path | None = None) -> list[Path]:
    """Write the run's tables (per topic, or the one wide table) or its well log; their
    paths."""
    if fmt not in FORMATS:
        raise ExportError(f"--format: value {fmt!r} is not one of {', '.join(FORMATS)}")
    if wide_hz is not None and not (math.isfinite(wide_hz) and wide_hz > 0.0):
        raise ExportError(f"--wide: value {wide_hz!r} Hz must be a positive rate")
    if fmt in LOG_FORMATS and (topics or wide_hz is not None):
        raise ExportError(f"--format {fmt}: a well log has its own channels "
                          f"(drill_bag.well_log); --topics and --wide are for "
                          f"{' and '.join(TABLE_FORMATS)}")
    mcap = run_mcap(run_dir)
    out = output or run_dir / EXPORT_DIR
    if fmt in LOG_FORMATS:
        try:
            log = well_log.run_log(run_dir, mcap)
        except (OSError, ValueError) as err:
            raise ExportError(str(err)) from err
        out.mkdir(parents=True, exist_ok=True)
        if fmt == "las":
            return [las_export.write_las(log, out / f"{run_dir.name}.las")]
        return witsml_export.write_witsml(log, out / "witsml")
    tables = topic_tables(mcap, topics)
    out.mkdir(parents=True, exist_ok=True)
    if wide_hz is not None:
        return [write_table(wide_table(tables, wide_hz), out / f"wide-{wide_hz:g}hz.{fmt}", fmt)]
    return [write_table(table, out / f"{file_stem(topic)}.{fmt}", fmt)
            for topic, table in tables.items()]


def add_arguments(parser) -> None:
    """``rig export``'s options."""
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--format", choices=FORMATS, default="csv",
                        help="tables (csv, parquet) or a well log (las: LAS 2.0, witsml: "
                             "WITSML 2.1 well, wellbore and log)")
    parser.add_argument("--topics", nargs="+", help="default: every recorded topic")
    parser.add_argument("--wide", type=float, metavar="RATE_HZ",
                        help="one table resampled at this rate (zero-order hold) instead of "
                             "one per topic")
    parser.add_argument("--output", type=Path, help="default: RUN_DIR/export")


def main(args) -> int:
    try:
        paths = export(args.run_dir, args.format, args.topics, args.wide, args.output)
    except ExportError as err:
        print(f"[rig] export: {err}", file=sys.stderr, flush=True)
        return 2
    for path in paths:
        print(f"[rig] wrote {path}")
    return 0
