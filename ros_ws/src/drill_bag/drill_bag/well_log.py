"""The rig's well log: which channels a drilling data system gets, in which units, from
which messages. One table read by the LAS and WITSML exports (drill_bag.las_export,
drill_bag.witsml_export) and by the live WITS0 stream (drill_bag.wits0).

Plain Python (no rclpy). A channel's value is computed from a *snapshot* of the rig: the
sensor sample (drill_msgs/RigMeasurement) and the actuator frames in force at its stamp
(the mud pump's discharge pressure, the choke's opening), plus two facts of the run (the
bit depth at the start, from the run's well.yaml, and the first pit reading). Values are
SI inside; each channel's ``scale`` converts to the exported unit, the WITS metric unit
of its item (kPa, L/min, m, m3, %), written with its Energistics UOM symbol. The
mnemonics are WITS record 01's short ones; the MPD channels, which record 01 has no item
for, go into its spare items 0141-0144 (docs/exports-and-sweeps.md lists them).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from drill_bag import mcap_io
from drill_core.config import Well, load_section
from drill_core.surface_flows import delta_flow_m3s
from drill_core.units import LPM_PER_M3S, N_PER_KN, PA_PER_KPA
from drill_core.well import build_geometry
from drill_ros import topic_names

FRAME_ACTUATORS = ("mud_pump", "choke")   # the frames a channel reads


@dataclass
class RigSnapshot:
    """What the channels read at one sensor stamp (messages as rclpy or the MCAP decoder
    gives them: the same field names)."""
    measurement: object                       # drill_msgs/RigMeasurement
    frames: dict = field(default_factory=dict)  # actuator name -> its ActuatorFrame in force
    stamp_ns: int = 0
    bit_depth_start_m: float = math.nan       # the bit's measured depth at the start [m]
    pit_volume_start_m3: float = math.nan     # the first pit reading of the run [m^3]

    def frame_output(self, actuator: str) -> float:
        """The actuator's output at the stamp (its frame holds output[i] from
        stamp + i * sample_period_s); NaN without a frame."""
        frame = self.frames.get(actuator)
        if frame is None or not len(frame.output):
            return math.nan
        start_ns = stamp_ns(frame)
        index = int(round((self.stamp_ns - start_ns) / (frame.sample_period_s * mcap_io.NS_PER_S)))
        return float(frame.output[min(max(index, 0), len(frame.output) - 1)])


@dataclass(frozen=True)
class Channel:
    """One channel of the log."""
    mnemonic: str           # LAS / WITSML mnemonic: WITS record 01's short one
    wits_item: str          # WITS record 01 item, 4 digits ("0108")
    description: str        # no colon (LAS separates a description with one)
    uom: str                # exported unit, an Energistics UOM symbol (also the LAS unit)
    scale: float            # exported value = SI value * scale
    value_si: Callable[[RigSnapshot], float]

    def value(self, snapshot: RigSnapshot) -> float:
        return self.value_si(snapshot) * self.scale


def _string_flow(s: RigSnapshot) -> float:
    m = s.measurement
    return m.string_flow_m3s if m.string_flow_valid else math.nan


CHANNELS = (
    Channel("DBTM", "0108", "Depth Bit (meas), the start depth less the block's travel", "m",
            1.0, lambda s: s.bit_depth_start_m - s.measurement.block_position_m),
    Channel("BPOS", "0112", "Block Position, drill-string position from the start, up",
            "m", 1.0, lambda s: s.measurement.block_position_m),
    Channel("HKLA", "0114", "Hookload (avg), the travelling block and the elevator's pull",
            "kN", 1.0 / N_PER_KN, lambda s: s.measurement.hook_load_n),
    Channel("SPPA", "0121", "Standpipe Pressure, the mud pump's discharge pressure", "kPa",
            1.0 / PA_PER_KPA, lambda s: s.frame_output("mud_pump")),
    Channel("CHKP", "0122", "Casing (Choke) Pressure, choke differential pressure", "kPa",
            1.0 / PA_PER_KPA, lambda s: s.measurement.choke_dp_pa),
    Channel("TVA", "0126", "Tank Volume (active)", "m3", 1.0,
            lambda s: s.measurement.pit_volume_m3),
    Channel("TVCA", "0127", "Tank Volume Change (active) since the start", "m3", 1.0,
            lambda s: s.measurement.pit_volume_m3 - s.pit_volume_start_m3),
    Channel("MFOA", "0129", "Mud Flow Out, the choke line's Coriolis meter", "L/min",
            LPM_PER_M3S, lambda s: s.measurement.return_flow_m3s),
    Channel("MFIA", "0130", "Mud Flow In, into the drill string (absent, pump off)", "L/min",
            LPM_PER_M3S, _string_flow),
    Channel("BHP", "0141", "Bottom-hole pressure at the reference depth (MPD, spare 1)",
            "kPa", 1.0 / PA_PER_KPA, lambda s: s.measurement.bhp_pa),
    Channel("BPPF", "0142", "Back-pressure pump flow (MPD, spare 2)", "L/min", LPM_PER_M3S,
            lambda s: s.measurement.bpp_flow_m3s),
    Channel("DFLO", "0143", "Delta flow, out less string and back-pressure pump in (MPD, "
            "spare 3)", "L/min", LPM_PER_M3S,
            lambda s: delta_flow_m3s(s.measurement) if s.measurement.string_flow_valid
            else math.nan),
    Channel("CHKO", "0144", "Choke opening (MPD, spare 4)", "%", 100.0,
            lambda s: s.frame_output("choke")),
)
BY_MNEMONIC = {c.mnemonic: c for c in CHANNELS}
LOG_TOPICS = (topic_names.MEASUREMENT, *(topic_names.actuator_frame(a) for a in FRAME_ACTUATORS))


class LiveRig:
    """A live run's newest sensor sample and the actuator frames in force, as a snapshot
    (what the gateways serve from: the WITS0 stream, the OPC-UA server). The first pit
    reading is the start of the pit change."""

    def __init__(self, well: Well):
        self.bit_depth_start_m = build_geometry(well).bit_depth_m
        self.measurement = None                 # drill_msgs/RigMeasurement, the newest
        self.frames: dict[str, object] = {}     # actuator -> its newest ActuatorFrame
        self.pit_volume_start_m3 = math.nan

    def on_measurement(self, m) -> None:
        if self.measurement is None:
            self.pit_volume_start_m3 = m.pit_volume_m3
        self.measurement = m

    def on_frame(self, actuator: str, frame) -> None:
        self.frames[actuator] = frame

    def snapshot(self) -> RigSnapshot | None:
        """The newest sample with the frames in force; None before the first."""
        m = self.measurement
        if m is None:
            return None
        return RigSnapshot(m, dict(self.frames), stamp_ns(m), self.bit_depth_start_m,
                           self.pit_volume_start_m3)


@dataclass(frozen=True)
class RunContext:
    """What a log says about its run (the run directory's launch.json and well.yaml)."""
    name: str                             # the run directory's name
    scenario: str                         # the scenario file's stem
    controller: str
    seed: str                             # "" for the scenario's own
    mismatch: str                         # the plant's mismatch member, "" for none
    mode: str                             # "fast" (stamps: simulated time) or "realtime"
    hole_depth_m: float                   # the well's measured depth [m]
    bit_depth_m: float                    # the bit's measured depth at the start [m]
    mud_density_kgm3: float               # the mud report's density (the model's) [kg/m^3]
    hole_diameter_m: float                # nominal hole size [m]


@dataclass(frozen=True)
class RunLog:
    """A recorded run as a well log: the channels' values at every sensor stamp."""
    stamps_ns: np.ndarray                 # the sensor stamps [ns since the epoch]
    values: dict[str, np.ndarray]         # mnemonic -> values in the channel's uom (NaN: none)
    context: RunContext

    @property
    def elapsed_s(self) -> np.ndarray:
        """Time since the first sample [s]."""
        return (self.stamps_ns - self.stamps_ns[0]) / mcap_io.NS_PER_S


def stamp_ns(message) -> int:
    """A message's header stamp [ns since the epoch]."""
    return message.header.stamp.sec * mcap_io.NS_PER_S + message.header.stamp.nanosec


def snapshots(mcap: Path, bit_depth_m: float):
    """The run's snapshots, one per sensor sample in stamp order, each with the frame of
    each actuator stamped last at or before it (whatever order the recorder logged them)."""
    actuator_of = {topic_names.actuator_frame(a): a for a in FRAME_ACTUATORS}
    measurements, frames = [], {a: [] for a in FRAME_ACTUATORS}
    for recorded in mcap_io.read_messages(mcap, LOG_TOPICS):
        message = mcap_io.decode(recorded)
        actuator = actuator_of.get(recorded.topic)
        (frames[actuator] if actuator else measurements).append((stamp_ns(message), message))
    measurements.sort(key=lambda pair: pair[0])
    frame_stamps = {}
    for actuator, pairs in frames.items():
        pairs.sort(key=lambda pair: pair[0])
        frame_stamps[actuator] = np.asarray([s for s, _ in pairs], dtype=np.int64)
    pit_start = measurements[0][1].pit_volume_m3 if measurements else math.nan
    for stamp, message in measurements:
        in_force = {}
        for actuator, stamps in frame_stamps.items():
            index = int(np.searchsorted(stamps, stamp, side="right")) - 1
            if index >= 0:
                in_force[actuator] = frames[actuator][index][1]
        yield RigSnapshot(message, in_force, stamp, bit_depth_m, pit_start)


def run_context(run_dir: Path) -> RunContext:
    """The run's context from its directory (launch.json, config/well.yaml)."""
    well = load_section(Well, run_dir / "config" / "well.yaml")
    geometry = build_geometry(well)
    launch_path = run_dir / "launch.json"
    launch = json.loads(launch_path.read_text()) if launch_path.exists() else {}
    seed = launch.get("seed")
    return RunContext(run_dir.name, Path(launch.get("scenario") or "").stem,
                      launch.get("controller") or "", "" if seed is None else str(seed),
                      launch.get("mismatch") or "", launch.get("mode") or "",
                      geometry.well_depth_m, geometry.bit_depth_m, well.mud.density_kgm3,
                      well.hole_diameter_m)


def run_log(run_dir: Path, mcap: Path) -> RunLog:
    """The well log of a run directory's recording."""
    context = run_context(run_dir)
    stamps, rows = [], []
    for snapshot in snapshots(mcap, context.bit_depth_m):
        stamps.append(snapshot.stamp_ns)
        rows.append([c.value(snapshot) for c in CHANNELS])
    if not rows:
        raise ValueError(f"{mcap}: no {topic_names.MEASUREMENT} messages: nothing to log")
    table = np.asarray(rows, dtype=float)
    return RunLog(np.asarray(stamps, dtype=np.int64),
                  {c.mnemonic: table[:, i] for i, c in enumerate(CHANNELS)}, context)
