"""Report of a drilling run (the drilling graph, drill_string) from its recording: the
stick-slip severity ((max - min) / mean bit speed), the stick-time fraction, the longest
stick and the rate of penetration, computed by drill_string's own metrics on every
simulated step of the scenario's evaluated frames (/drilling/truth); the mean loads; and
plots of bit speed, WOB, TOB and depth of cut. WOB and TOB are plotted as the rig
measures them, means over each sensor frame: the stop of a sticking bit puts a one-step
impulse on both that a plot of every step would show as a spike. SI in the summary,
drilling units (rpm, kN, kN m, mm, m/h) in the printed table and on the plots."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drill_bag import mcap_io
from drill_ros import topic_names as topics
from drill_string import (longest_stick_s, rate_of_penetration_m_s, stick_slip_severity,
                          stick_time_fraction)
from drill_string.parameters import rad_s_to_rpm
from drill_string.simulate import TRAJECTORY_FIELDS, Trajectory

SECONDS_PER_HOUR = 3600.0
_FLAGS = ("torsional_stick", "axial_stick", "off_bottom")      # the boolean step arrays
MEASURED = {topics.SURFACE: ("hook_load_n", "surface_torque_nm", "top_drive_speed_rad_s",
                             "block_position_m"),
            topics.DOWNHOLE: ("wob_n", "tob_nm", "bit_speed_rad_s", "depth_of_cut_m",
                              "bit_depth_m")}


def holds_drilling(mcap_path: Path) -> bool:
    """Whether a recording is of a drilling run."""
    return topics.DRILLING_TRUTH in mcap_io.topics(mcap_path)


@dataclass
class DrillingRecording:
    """A drilling run: every simulated step, the evaluated ones, the measured frames."""
    steps: Trajectory
    evaluated: Trajectory
    measured: dict          # field -> (stamps s, values), the sensor frames


def _stamp_s(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def load(mcap_path: Path) -> DrillingRecording:
    frames, measured = [], {}
    for rec, msg in mcap_io.decoded_messages(mcap_path, [topics.DRILLING_TRUTH, *MEASURED]):
        t = _stamp_s(msg)
        if rec.topic == topics.DRILLING_TRUTH:
            frames.append((t, msg.evaluated, {f: getattr(msg, f) for f in TRAJECTORY_FIELDS}))
            continue
        for name in MEASURED[rec.topic]:
            measured.setdefault(name, ([], []))
            measured[name][0].append(t)
            measured[name][1].append(getattr(msg, name))
    frames.sort(key=lambda f: f[0])

    def joined(selected) -> Trajectory:
        return Trajectory(**{f: np.concatenate([np.asarray(arrays[f], dtype=bool if
                                                           f in _FLAGS else float)
                                                for _, _, arrays in selected] or [np.empty(0)])
                             for f in TRAJECTORY_FIELDS})

    return DrillingRecording(joined(frames), joined([f for f in frames if f[1]]),
                             {k: (np.asarray(t), np.asarray(v)) for k, (t, v) in measured.items()})


def summarise(rec: DrillingRecording) -> dict:
    """The run's numbers (SI) over its evaluated steps."""
    ev = rec.evaluated
    if not ev.time_s.size:
        raise ValueError("the recording has no evaluated steps (/drilling/truth)")
    span = float(ev.time_s[-1] - ev.time_s[0])
    return {
        "duration_s": float(rec.steps.time_s[-1]) if rec.steps.time_s.size else 0.0,
        "evaluated_from_s": float(ev.time_s[0]),
        "evaluated_s": span,
        "steps": int(rec.steps.time_s.size),
        "stick_slip_severity": stick_slip_severity(ev),
        "stick_time_fraction": stick_time_fraction(ev),
        "longest_stick_s": longest_stick_s(ev),
        "rate_of_penetration_m_s": rate_of_penetration_m_s(ev),
        "bit_speed_mean_rad_s": float(np.mean(ev.bit_speed_rad_s)),
        "bit_speed_max_rad_s": float(np.max(ev.bit_speed_rad_s)),
        "top_drive_speed_mean_rad_s": float(np.mean(ev.top_drive_speed_rad_s)),
        "wob_mean_n": float(np.mean(ev.wob_n)),
        "tob_mean_nm": float(np.mean(ev.tob_nm)),
        "depth_of_cut_mean_m": float(np.mean(ev.depth_of_cut_m)),
        "hook_load_mean_n": float(np.mean(ev.hook_load_n)),
        "surface_torque_mean_nm": float(np.mean(ev.surface_torque_nm)),
        "surface_torque_max_nm": float(np.max(ev.surface_torque_nm)),
        "axial_stick_fraction": float(np.mean(ev.axial_stick)),
        "off_bottom_fraction": float(np.mean(ev.off_bottom)),
    }


def format_table(name: str, s: dict) -> str:
    """Human-readable summary in drilling units."""
    return "\n".join([
        f"Run: {name} (drilling)",
        f"  duration                      {s['duration_s']:.1f} s ({s['steps']} steps); metrics over "
        f"{s['evaluated_from_s']:.1f}-{s['evaluated_from_s'] + s['evaluated_s']:.1f} s",
        f"  stick-slip severity           {s['stick_slip_severity']:.2f} "
        "((max - min) / mean bit speed)",
        f"  stick-time fraction           {s['stick_time_fraction']:.3f} "
        f"(longest stick {s['longest_stick_s']:.2f} s)",
        f"  rate of penetration           {s['rate_of_penetration_m_s'] * SECONDS_PER_HOUR:.1f} m/h",
        f"  bit speed                     mean {rad_s_to_rpm(s['bit_speed_mean_rad_s']):.1f} rpm, "
        f"max {rad_s_to_rpm(s['bit_speed_max_rad_s']):.1f} rpm (top drive "
        f"{rad_s_to_rpm(s['top_drive_speed_mean_rad_s']):.1f} rpm)",
        f"  WOB / TOB (mean)              {s['wob_mean_n'] / 1e3:.1f} kN / "
        f"{s['tob_mean_nm'] / 1e3:.2f} kN m (depth of cut {s['depth_of_cut_mean_m'] * 1e3:.2f} mm)",
        f"  hook load / surface torque    {s['hook_load_mean_n'] / 1e3:.0f} kN / "
        f"{s['surface_torque_mean_nm'] / 1e3:.2f} kN m mean "
        f"(torque max {s['surface_torque_max_nm'] / 1e3:.2f} kN m)",
        f"  bit axially stuck / off bottom {s['axial_stick_fraction']:.3f} / "
        f"{s['off_bottom_fraction']:.3f} of the time",
    ])


def plot(rec: DrillingRecording, out_dir: Path) -> list[Path]:
    """drilling.png (bit speed, WOB, TOB, depth of cut) and surface.png (hook load,
    surface torque, block and bit travel)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    st, m = rec.steps, rec.measured
    start = rec.evaluated.time_s[0] if rec.evaluated.time_s.size else None
    paths = []

    def finish(fig, axes, name):
        for ax in axes:
            if start is not None and start > st.time_s[0]:
                ax.axvline(start, color="k", ls=":", lw=0.8)
        axes[-1].set_xlabel("time [s] (dotted: metrics from here)")
        fig.tight_layout()
        paths.append(out_dir / name)
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)

    fig, axes = plt.subplots(4, 1, figsize=(10, 10), sharex=True)
    axes[0].plot(st.time_s, rad_s_to_rpm(st.bit_speed_rad_s), lw=0.5, label="bit (every step)")
    axes[0].plot(m["top_drive_speed_rad_s"][0], rad_s_to_rpm(m["top_drive_speed_rad_s"][1]),
                 "k--", lw=0.8, label="top drive (measured)")
    axes[0].set_ylabel("speed [rpm]")
    axes[0].legend(fontsize=7, loc="upper left")
    for ax, key, scale, unit in ((axes[1], "wob_n", 1e-3, "WOB [kN]"),
                                 (axes[2], "tob_nm", 1e-3, "TOB [kN m]")):
        ax.plot(m[key][0], m[key][1] * scale, lw=0.8)
        ax.set_ylabel(unit)
    axes[3].plot(st.time_s, st.depth_of_cut_m * 1e3, lw=0.5)
    axes[3].set_ylabel("depth of cut [mm]")
    fig.suptitle("Bit: speed (every step), WOB and TOB (measured, frame means), depth of cut")
    finish(fig, axes, "drilling.png")

    fig, axes = plt.subplots(3, 1, figsize=(10, 7), sharex=True)
    axes[0].plot(m["hook_load_n"][0], m["hook_load_n"][1] * 1e-3, lw=0.8)
    axes[0].set_ylabel("hook load [kN]")
    axes[1].plot(m["surface_torque_nm"][0], m["surface_torque_nm"][1] * 1e-3, lw=0.8)
    axes[1].set_ylabel("surface torque [kN m]")
    axes[2].plot(m["block_position_m"][0], m["block_position_m"][1], label="block")
    axes[2].plot(m["bit_depth_m"][0], m["bit_depth_m"][1], lw=0.8, label="bit")
    axes[2].set_ylabel("travel, down [m]")
    axes[2].legend(fontsize=7)
    fig.suptitle("Surface measurements (frame means) and block and bit travel")
    finish(fig, axes, "surface.png")
    return paths


def report(mcap_path: Path, plots_dir: Path, name: str) -> tuple[dict, list[Path], str]:
    """Summary, plots and the printed table of one drilling recording."""
    rec = load(mcap_path)
    summary = summarise(rec)
    return summary, plot(rec, plots_dir), format_table(name, summary)
