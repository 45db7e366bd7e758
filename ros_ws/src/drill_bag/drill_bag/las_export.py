"""``rig export --format las``: a run's well log (drill_bag.well_log) as a LAS 2.0 file,
written by ``lasio``: time-indexed (``TIME``, seconds since the first sensor sample), one
curve per channel in its unit, the run in the well and parameter sections. A channel
without a value at a sample (the flow in while the pump is off) is the file's NULL.
"""
from __future__ import annotations

from pathlib import Path

import lasio
import numpy as np

from drill_bag.well_log import CHANNELS, RunLog

NULL_VALUE = -999.25
INDEX = ("TIME", "s", "Time since the first sensor sample")


def las_file(log: RunLog) -> lasio.LASFile:
    """The log as a lasio LAS 2.0 object."""
    c = log.context
    las = lasio.LASFile()
    las.version["VERS"].value = 2.0
    las.well["NULL"].value = NULL_VALUE
    for mnemonic, value in (("WELL", "reference well"), ("COMP", "virtual drilling rig"),
                            ("FLD", c.scenario), ("LOC", c.name), ("SRVC", "rig export"),
                            ("UWI", c.name)):
        las.well[mnemonic].value = value
    las.well["DATE"].value = str(np.datetime64(int(log.stamps_ns[0]), "ns").astype("datetime64[ms]"))
    for mnemonic, unit, value, description in (
            ("RUN", "", c.name, "run directory"), ("SCEN", "", c.scenario, "scenario"),
            ("CTRL", "", c.controller, "controller"), ("SEED", "", c.seed or "scenario's",
                                                        "noise seed"),
            ("MISM", "", c.mismatch or "none", "plant's mismatch to the model"),
            ("MODE", "", c.mode, "in fast mode the stamps are simulated time from 1970-01-01"),
            ("TDEP", "m", round(c.hole_depth_m, 3), "hole depth (meas)"),
            ("BDEP", "m", round(c.bit_depth_m, 3), "bit depth at the start (meas)"),
            ("BS", "m", c.hole_diameter_m, "nominal hole size"),
            ("MDEN", "kg/m3", c.mud_density_kgm3, "mud density (the mud report's)")):
        las.params.append(lasio.HeaderItem(mnemonic, unit, value, description))
    name, unit, description = INDEX
    las.append_curve(name, log.elapsed_s, unit=unit, descr=description)
    for channel in CHANNELS:
        las.append_curve(channel.mnemonic, log.values[channel.mnemonic], unit=channel.uom,
                         descr=f"WITS {channel.wits_item} {channel.description}")
    return las


def write_las(log: RunLog, path: Path) -> Path:
    """Write the log as LAS 2.0."""
    with open(path, "w") as f:
        las_file(log).write(f, version=2.0, wrap=False, fmt="%.10g")
    return path
