"""``rig export --format witsml``: a run's well log (drill_bag.well_log) as WITSML 2.1
data objects, built with the Energistics types (``energyml-witsml2-1``) and serialised by
their xsdata binding: ``well.xml`` (the rig's well), ``wellbore.xml`` (the run) and
``log.xml``, a Log with one ChannelSet indexed by elapsed time (``TIME``, s since the
first sensor sample), one Channel per log channel with its Energistics unit of measure,
the data as the ChannelSet's JSON rows ``[[index], [value, ...]]`` (null: no value).

The objects reference each other and their property kinds by uuid; the uuids are derived
from the run directory's name (uuid5), so exporting a run twice gives the same objects.
The property kinds are named by their Energistics titles; their uuids are this
exporter's, not the dictionary's.
"""
from __future__ import annotations

import json
import math
import uuid
from datetime import datetime, timezone
from pathlib import Path

from energyml.eml.v2_3 import commonv2 as eml
from energyml.witsml.v2_1 import witsmlv2 as witsml
from xsdata.formats.dataclass.parsers import XmlParser
from xsdata.formats.dataclass.parsers.config import ParserConfig
from xsdata.formats.dataclass.serializers import XmlSerializer
from xsdata.formats.dataclass.serializers.config import SerializerConfig
from xsdata.models.datatype import XmlDateTime

from drill_bag.well_log import CHANNELS, RunLog

SCHEMA_VERSION = "2.1"
ORIGINATOR = "virtual drilling rig"
INDEX_MNEMONIC = "TIME"
UUID_NAMESPACE = uuid.UUID("6f1c1e52-3c1d-4d8e-9a43-0f6f3ad0b6a1")   # this exporter's
NAMESPACES = {"witsml": "http://www.energistics.org/energyml/data/witsmlv2",
              "eml": "http://www.energistics.org/energyml/data/commonv2",
              "xsi": "http://www.w3.org/2001/XMLSchema-instance"}
PROPERTY_KIND = {"m": "length", "kPa": "pressure", "kN": "force", "m3": "volume",
                 "L/min": "volume per time", "%": "dimensionless"}   # unit -> property kind


def _uuid(*parts: str) -> str:
    return str(uuid.uuid5(UUID_NAMESPACE, "/".join(parts)))


def _citation(title: str, created: datetime, description: str | None = None) -> eml.Citation:
    return eml.Citation(title=title, originator=ORIGINATOR, format=ORIGINATOR,
                        creation=XmlDateTime.from_datetime(created), description=description)


def _reference(obj, qualified_type: str) -> eml.DataObjectReference:
    return eml.DataObjectReference(uuid=obj.uuid, qualified_type=qualified_type,
                                   title=obj.citation.title)


def _property_kind(uom: str, run: str) -> eml.DataObjectReference:
    title = PROPERTY_KIND[uom]
    return eml.DataObjectReference(uuid=_uuid(run, "property kind", title),
                                   qualified_type="eml23.PropertyKind", title=title)


def _json_number(value: float):
    return value if math.isfinite(value) else None


def objects(log: RunLog, created: datetime | None = None):
    """(Well, Wellbore, Log) of the run."""
    created = created or datetime.now(timezone.utc)
    c = log.context
    active = eml.ActiveStatusKind.INACTIVE
    well = witsml.Well(citation=_citation("reference well", created), uuid=_uuid(c.name, "well"),
                       schema_version=SCHEMA_VERSION, active_status=active)
    wellbore = witsml.Wellbore(citation=_citation(c.name, created),
                               uuid=_uuid(c.name, "wellbore"), schema_version=SCHEMA_VERSION,
                               active_status=active,
                               well=_reference(well, "witsml21.Well"))
    wellbore_ref = _reference(wellbore, "witsml21.Wellbore")
    company = eml.DataObjectReference(uuid=_uuid(c.name, "business associate"),
                                      qualified_type="eml23.BusinessAssociate", title=ORIGINATOR)
    index = witsml.ChannelIndex(index_kind=eml.DataIndexKind.ELAPSED_TIME, uom="s",
                                direction=eml.IndexDirection.INCREASING,
                                mnemonic=INDEX_MNEMONIC)
    channels = [witsml.Channel(
        citation=_citation(ch.description, created), uuid=_uuid(c.name, "channel", ch.mnemonic),
        schema_version=SCHEMA_VERSION, active_status=active, mnemonic=ch.mnemonic,
        global_mnemonic=f"WITS{ch.wits_item}", data_kind=witsml.ChannelDataKind.DOUBLE,
        uom=ch.uom, channel_property_kind=_property_kind(ch.uom, c.name),
        logging_company=company, index=[index], wellbore=wellbore_ref) for ch in CHANNELS]
    rows = [[[float(t)], [_json_number(float(log.values[ch.mnemonic][i])) for ch in CHANNELS]]
            for i, t in enumerate(log.elapsed_s)]
    elapsed = log.elapsed_s
    interval = eml.ElapsedTimeInterval(
        start_elapsed_time=eml.TimeMeasure(value=float(elapsed[0]), uom="s"),
        end_elapsed_time=eml.TimeMeasure(value=float(elapsed[-1]), uom="s"))
    seed = f"seed {c.seed}" if c.seed else "the scenario's seed"
    description = (f"scenario {c.scenario}, controller {c.controller}, {seed}, plant "
                   f"mismatch {c.mismatch or 'none'}, {c.mode} mode")
    channel_set = witsml.ChannelSet(
        citation=_citation(f"{c.name} time log", created), uuid=_uuid(c.name, "channel set"),
        schema_version=SCHEMA_VERSION, active_status=active, index=[index], channel=channels,
        data=witsml.ChannelData(data=json.dumps(rows, separators=(",", ":"))),
        primary_index_interval=interval, wellbore=wellbore_ref)
    log_object = witsml.Log(
        citation=_citation(f"{c.name} time log", created, description),
        uuid=_uuid(c.name, "log"), schema_version=SCHEMA_VERSION, active_status=active,
        run_number=c.name, primary_index_interval=interval,
        nominal_hole_size=eml.LengthMeasureExt(value=c.hole_diameter_m, uom="m"),
        channel_set=[channel_set], wellbore=wellbore_ref)
    return well, wellbore, log_object


def to_xml(obj) -> str:
    """One data object as WITSML XML (the Energistics namespaces)."""
    return XmlSerializer(config=SerializerConfig(indent="  ")).render(obj, ns_map=NAMESPACES)


def parse(xml: str, cls):
    """Parse WITSML XML into ``cls`` strictly: an unknown element or a value its type
    does not take is an error."""
    config = ParserConfig(fail_on_unknown_properties=True, fail_on_unknown_attributes=True,
                          fail_on_converter_warnings=True)
    return XmlParser(config=config).from_string(xml, cls)


def write_witsml(log: RunLog, directory: Path) -> list[Path]:
    """Write well.xml, wellbore.xml and log.xml into ``directory``; their paths."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, obj in zip(("well", "wellbore", "log"), objects(log)):
        path = directory / f"{name}.xml"
        path.write_text(to_xml(obj))
        paths.append(path)
    return paths
