"""Run report from a recording: the paper's Table 7 figures, BHP-window violations,
peak surge/swab, estimator errors against the truth (the estimation study's result,
paper sec. 4.3), solve-time statistics and PNG plots (pressures, flows and volumes in the
display units chosen, drill_core.units.Display: bar, L/min, L or psi, gpm, bbl, on the
plots and in the printed table only; summary.json stays SI). An open-loop run (the sequencer's
commands, no setpoints) has no tracking figures: they are reported as n/a. A drilling
run's recording gets the drilling summary instead (drill_analysis.drilling_report)."""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import NamedTuple
from pathlib import Path

import numpy as np

from drill_bag import mcap_io

from drill_analysis import band_report, drilling_report, prediction_report, trip_sheet_report
from drill_analysis import well_control_report as well_control
from drill_core.config import load_rig
from drill_core.rig_root import rig_root
from drill_ros import topic_names as topics
from drill_ros.stamps import to_ns
from drill_core.units import METRIC_DISPLAY, Display

ARRIVAL_TOLERANCE_M = 0.5     # a trip leg ends when the string is this close to its target
FINAL_WINDOW_S = 30.0           # the estimator's final bias: mean error over the run's last 30 s
SETTLE_S = 30.0                 # band time "settled": after the first 30 s of a run (issue targets)
OPEN_LOOP_ADVISOR = "sequencer"
EVENT_SOURCES = {topics.RIG_EVENTS: "rig", topics.PROTECTION_EVENTS: "protection"}
RUN_CONFIG = "config"       # a run directory's copy of the configuration it ran with


class RecordedEvent(NamedTuple):
    """One event of a recording (drill_msgs/OperatorEvent; codes: drill_core.event_codes)."""
    t_s: float
    source: str       # "rig" or "protection" (EVENT_SOURCES)
    kind: str
    code: str
    value: float      # the code's SI value, NaN where it carries none
    text: str

    def as_dict(self) -> dict:
        """For summary.json (a NaN value as null)."""
        return self._asdict() | {"value": self.value if math.isfinite(self.value) else None}
# series key, PlantTruth field of the formation and the pit
TRUTH_FORMATION_FIELDS = (("pit_gain", "pit_gain_m3"), ("influx_volume", "influx_volume_m3"),
                          ("loss_volume", "loss_volume_m3"), ("pore", "pore_pressure_pa"),
                          ("fracture", "fracture_pressure_pa"))


# a realtime run's frame lateness against its timer's schedule, the periods the timer
# skipped (drill_plant.frame_lateness)
REALTIME_MARGINS = ("frame_late_p99_s", "frame_late_max_s", "frames_skipped")


@dataclass
class Series:
    """Time series pulled from one recording (SI)."""
    t: dict = field(default_factory=dict)
    v: dict = field(default_factory=dict)
    advisor: str = ""       # source of the advisor commands (nmpc, baseline, sequencer)
    events: list = field(default_factory=list)    # RecordedEvent: rig, protection
    plant_status: dict = field(default_factory=dict)   # the plant's last NodeStatus values
    # the NMPC's solves (stamp ns, predicted times after it [s], predicted BHP [Pa]) and the
    # rig floor's phase by stamp ns (drill_analysis.prediction_report)
    predictions: list = field(default_factory=list)
    floor_phases: dict = field(default_factory=dict)

    def add(self, key: str, t_s: float, value) -> None:
        self.t.setdefault(key, []).append(t_s)
        self.v.setdefault(key, []).append(value)

    def get(self, key: str):
        return np.asarray(self.t.get(key, []), float), np.asarray(self.v.get(key, []), float)


def _stamp_s(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def load_series(mcap_path: Path) -> Series:
    s = Series()
    wanted = [topics.TRUTH, topics.MEASUREMENT, topics.ESTIMATE, topics.NMPC_STATUS,
              topics.COMMAND, topics.MACHINE_COMMAND, topics.SETPOINTS, topics.status("plant"),
              topics.FLOOR, *EVENT_SOURCES]
    for rec, msg in mcap_io.decoded_messages(mcap_path, wanted):
        t = _stamp_s(msg)
        if rec.topic == topics.TRUTH:
            s.add("bhp", t, msg.bhp_pa)
            s.add("choke_dp", t, msg.annulus_pressure_pa[0])
            s.add("position", t, msg.string_position_m)
            s.add("velocity", t, msg.string_velocity_mps)
            s.add("block", t, msg.block_position_m)
            s.add("friction", t, list(msg.annulus_friction_pa))
            s.add("choke_opening", t, msg.choke_opening)
            s.add("bpp", t, msg.bpp_flow_m3s)
            s.add("spp", t, msg.spp_pa)
            s.add("choke_flow", t, msg.annulus_flow_m3s[0])
            for key, name in TRUTH_FORMATION_FIELDS:        # absent in older recordings: NaN
                s.add(key, t, getattr(msg, name, math.nan))
        elif rec.topic == topics.MEASUREMENT:
            s.add("bhp_meas", t, msg.bhp_pa)
            s.add("pit_meas", t, getattr(msg, "pit_volume_m3", math.nan))
        elif rec.topic in EVENT_SOURCES:
            # a recording made before events had codes reads with an empty code, NaN value
            s.events.append(RecordedEvent(t, EVENT_SOURCES[rec.topic], msg.kind,
                                          getattr(msg, "code", ""),
                                          getattr(msg, "value", math.nan), msg.text))
        elif rec.topic == topics.ESTIMATE:
            s.add("bhp_est", t, msg.bhp_pa)
            s.add("friction_est", t, list(msg.friction_pa))
            s.add("nis", t, msg.nis)
            s.add("string_flow_observable", t, float(msg.string_flow_observable))
            s.add("influx_est", t, getattr(msg, "bottom_influx_m3s", math.nan))
        elif rec.topic == topics.NMPC_STATUS:
            s.add("solve_time", t, msg.solve_time_s)
            s.add("fallback", t, 0.0 if msg.fallback == "none" else 1.0)
            s.add("bhp_ref_smoothed", t, msg.bhp_ref_pa)
            s.predictions.append((to_ns(msg.header.stamp), list(msg.predicted_time_s),
                                  list(msg.predicted_bhp_pa)))
        elif rec.topic == topics.FLOOR:
            s.floor_phases[to_ns(msg.header.stamp)] = str(msg.phase)
        elif rec.topic == topics.COMMAND:
            s.advisor = msg.source
        elif rec.topic == topics.MACHINE_COMMAND:
            manual = getattr(msg, "choke_manual", False)     # absent in older recordings
            s.add("cmd_block_ref", t, msg.block_position_ref_m)
            s.add("cmd_choke_flow", t, math.nan if manual else msg.choke_flow_ref_m3s)
            s.add("cmd_choke_opening", t, msg.choke_opening_ref if manual else math.nan)
            s.add("cmd_bpp", t, msg.bpp_flow_m3s)
            s.add("cmd_spp", t, msg.spp_pa)
        elif rec.topic == topics.status("plant"):
            s.plant_status = dict(zip(msg.keys, msg.values))
        elif rec.topic == topics.SETPOINTS:
            s.add("bhp_ref", t, msg.bhp_ref_pa)
            s.add("bhp_band", t, msg.bhp_band_pa)
            s.add("block_target", t, msg.block_position_target_m)
            s.add("trip_speed_limit", t, msg.trip_speed_limit_mps)
    return s


def _held(t_query, t_src, v_src, default):
    """Zero-order hold of a step signal (setpoints) at the query times."""
    if len(t_src) == 0:
        return np.full((len(t_query),) + np.shape(default), default, float)
    idx = np.clip(np.searchsorted(t_src, t_query, side="right") - 1, 0, None)
    return np.asarray(v_src)[idx]


def references(s: Series, t):
    """BHP reference, half band and block target at the truth times."""
    _, bhp = s.get("bhp")
    ref, band, target = (_held(t, *s.get(key), default)
                         for key, default in (("bhp_ref", bhp[0]), ("bhp_band", 2e5),
                                              ("block_target", 0.0)))
    ref = np.where(np.isfinite(ref) & (ref > 0), ref, bhp[0])
    return ref, band, target


def tracks_setpoints(s: Series) -> bool:
    """False for an open-loop run: its commands follow a schedule and no setpoint is tracked."""
    return s.advisor != OPEN_LOOP_ADVISOR


def trip_legs(t, pos, target, tolerance_m: float = ARRIVAL_TOLERANCE_M) -> list:
    """One (target m, seconds to arrive) per block target in force: the time from the target
    being set until the string first comes within ``tolerance_m`` of it (None: it never
    did before the next target). A first target the string already sits on is no leg."""
    starts = [0] + [i for i in range(1, len(target)) if target[i] != target[i - 1]]
    legs = []
    for k, start in enumerate(starts):
        end = starts[k + 1] if k + 1 < len(starts) else len(target)
        near = np.nonzero(np.abs(pos[start:end] - target[start]) <= tolerance_m)[0]
        if start == 0 and len(near) and near[0] == 0:
            continue
        legs.append((float(target[start]), float(t[start + near[0]] - t[start]) if len(near) else None))
    return legs


def trip_overshoot_m(pos, target) -> float:
    """How far the string ran past a block target while that target was in force, at most
    over the legs (0: it never passed one). A target the string started on is no leg."""
    starts = [i for i in range(1, len(target)) if target[i] != target[i - 1]]
    worst = 0.0
    for k, start in enumerate(starts):
        end = starts[k + 1] if k + 1 < len(starts) else len(target)
        direction = np.sign(target[start] - pos[start])
        passed = direction * (pos[start:end] - target[start])
        worst = max(worst, float(np.max(passed)))
    return worst


def _tracking(s: Series, t, bhp, pos) -> dict:
    """Table 7 errors and control-band violations against the setpoints in force."""
    ref, band, target = references(s, t)
    return tracking_metrics(t, bhp, pos, ref, band, target)


def tracking_metrics(t, bhp, pos, ref, band, target) -> dict:
    """Table 7 errors, control-band statistics (all of the run, and after the first
    SETTLE_S) and trip legs, from truth samples and the references held at their times."""
    e_bhp = bhp - ref
    e_pos = pos - target
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    outside = np.abs(e_bhp) > band
    excursion = np.where(outside, np.abs(e_bhp) - band, 0.0)
    settled = t - t[0] >= SETTLE_S if len(t) else outside
    return {
        "block_position_mean_error_m": float(np.mean(e_pos)),
        "block_position_rmse_m": float(np.sqrt(np.mean(e_pos ** 2))),
        "bhp_mean_error_pa": float(np.mean(e_bhp)),
        "bhp_rmse_pa": float(np.sqrt(np.mean(e_bhp ** 2))),
        "bhp_rmse_settled_pa": float(np.sqrt(np.mean(e_bhp[settled] ** 2)))
        if np.any(settled) else math.nan,
        "bhp_window_violations": int(np.count_nonzero(np.diff(outside.astype(int)) == 1)
                                     + int(outside[0])) if len(outside) else 0,
        "bhp_worst_excursion_pa": float(np.max(excursion)) if len(excursion) else 0.0,
        "bhp_time_outside_s": float(np.count_nonzero(outside) * dt),
        "bhp_time_outside_settled_s": float(np.count_nonzero(outside & settled) * dt),
        "trip_legs": trip_legs(t, pos, target),
        "trip_overshoot_m": trip_overshoot_m(pos, target),
    }


def _estimation(s: Series, t, bhp) -> dict:
    """Estimate minus truth: BHP and per-path annular friction as mean, RMSE and final bias
    (mean over the last FINAL_WINDOW_S; the paper's estimation study, sec. 4.3, reports the
    BHP estimate converging with a constant bias)."""
    t_est, bhp_est = s.get("bhp_est")
    if not len(t_est):
        return {}
    final = t_est >= t_est[-1] - FINAL_WINDOW_S
    err = bhp_est - np.interp(t_est, t, bhp)
    out = {"bhp_estimate_mean_error_pa": float(np.mean(err)),
           "bhp_estimate_rmse_pa": float(np.sqrt(np.mean(err ** 2))),
           "bhp_estimate_final_bias_pa": float(np.mean(err[final]))}
    _, fr = s.get("friction")
    _, fe = s.get("friction_est")
    if fr.ndim == 2 and fe.ndim == 2 and fe.shape == (len(t_est), fr.shape[1]):
        f_err = fe - np.column_stack([np.interp(t_est, t, fr[:, i]) for i in range(fr.shape[1])])
        out["friction_estimate_mean_error_pa"] = [float(v) for v in np.mean(f_err, axis=0)]
        out["friction_estimate_rmse_pa"] = [float(v) for v in np.sqrt(np.mean(f_err ** 2, axis=0))]
        out["friction_estimate_final_bias_pa"] = [float(v) for v in np.mean(f_err[final], axis=0)]
    _, observable = s.get("string_flow_observable")
    period = float(np.median(np.diff(t_est))) if len(t_est) > 1 else 0.0
    out["string_flow_unobservable_s"] = float(np.count_nonzero(observable == 0.0) * period)
    return out


def run_config_dir(run_dir: Path | None) -> Path:
    """The configuration a run ran with: its directory's copy (RUN_CONFIG), else (a run
    made before runs kept one, or a recording without its directory) this checkout's."""
    if run_dir is not None and (run_dir / RUN_CONFIG).is_dir():
        return run_dir / RUN_CONFIG
    return rig_root() / "config"


def summarise(s: Series, config_dir: Path | None = None) -> dict:
    """The run's numbers (SI): the paper's Table 7 form and window statistics (runs that
    track setpoints), surge/swab, estimator errors and solve times. The kick detector's
    thresholds, against which the estimator's influx estimate is judged too, are those of
    ``config_dir`` (None: run_config_dir's fallback)."""
    t, bhp = s.get("bhp")
    _, pos = s.get("position")
    _, solve = s.get("solve_time")
    _, fallback = s.get("fallback")
    out = {
        "duration_s": float(t[-1] - t[0]) if len(t) else 0.0,
        "peak_surge_pa": float(np.max(bhp - bhp[0])),
        "peak_swab_pa": float(np.min(bhp - bhp[0])),
        "max_string_speed_mps": float(np.max(np.abs(s.get("velocity")[1]))) if len(t) else 0.0,
        "trip_distance_m": float(np.max(pos) - np.min(pos)) if len(pos) else 0.0,
    }
    if tracks_setpoints(s):
        out.update(_tracking(s, t, bhp, pos))
    detector = load_rig(config_dir or run_config_dir(None)).protection.kick_detection
    out.update(well_control.summarise(s, t, bhp, detector))
    out.update(_estimation(s, t, bhp))
    out.update({key: float(s.plant_status[key]) for key in REALTIME_MARGINS
                if key in s.plant_status})
    if len(solve):
        out.update({
            "solve_time_median_s": float(np.median(solve)),
            "solve_time_p95_s": float(np.percentile(solve, 95)),
            "solve_time_p99_s": float(np.percentile(solve, 99)),
            "solve_time_max_s": float(np.max(solve)),
            "solves": int(len(solve)),
            "fallbacks": int(np.sum(fallback)),
        })
    return out


def format_legs(legs) -> str:
    """'to 28.0 m in 61 s, to 0.0 m in 75 s' (a leg never completed: 'not reached')."""
    if not legs:
        return "none"
    return ", ".join(f"to {target:.1f} m " + (f"in {time_s:.0f} s" if time_s is not None
                                               else "not reached") for target, time_s in legs)


def plant_text(mismatch: dict | None) -> str:
    """The run's plant against the model, for the printed table."""
    if not mismatch:
        return "the model's own (config/well.yaml)"
    changes = ", ".join(f"{k} {v}" for k, v in mismatch["mismatch"].items())
    return f"not the model: {mismatch['name']} ({changes or 'no change'})"


def format_table(name: str, summary: dict, baseline: dict | None = None,
                 units: Display = METRIC_DISPLAY, multi_stand: bool = False) -> str:
    """Human-readable summary in drilling units (``units``: metric or field). A multi-stand
    trip's (``multi_stand``) leaves out the block's distance, position error and legs: the
    string's position counts from a new top after each connection, so each stand's move
    is read in the trip sheet instead."""
    p, bar = units.factor("pressure"), units.symbol("pressure")
    rows = [
        f"Run: {name}",
        f"  duration                      {summary['duration_s']:.0f} s",
        f"  plant                         {plant_text(summary.get('plant_mismatch'))}",
        f"  string speed                  max {summary['max_string_speed_mps']:.2f} m/s "
        "(each stand's move: the trip sheet below)" if multi_stand else
        f"  trip distance                 {summary['trip_distance_m']:.1f} m "
        f"(max string speed {summary['max_string_speed_mps']:.2f} m/s)",
    ]
    if "bhp_rmse_pa" in summary:
        rows += [
            "  Table 7 form                  mean error      RMSE",
            *(() if multi_stand else (
                f"    block position [m]         {summary['block_position_mean_error_m']:10.3f}  "
                f"{summary['block_position_rmse_m']:9.3f}",)),
            f"    BHP [{bar}]                  {summary['bhp_mean_error_pa'] * p:10.3f}  "
            f"{summary['bhp_rmse_pa'] * p:9.3f}  (after the first {SETTLE_S:.0f} s: "
            f"{summary['bhp_rmse_settled_pa'] * p:.3f})",
            f"  BHP window violations         {summary['bhp_window_violations']} "
            f"(worst {summary['bhp_worst_excursion_pa'] * p:.2f} {bar} outside, "
            f"{summary['bhp_time_outside_s']:.1f} s outside, "
            f"{summary['bhp_time_outside_settled_s']:.1f} s after the first {SETTLE_S:.0f} s)",
            *(() if multi_stand else (
                f"  trip legs                     {format_legs(summary['trip_legs'])} "
                f"(past the target by {summary['trip_overshoot_m']:.2f} m at most)",)),
        ]
    else:
        rows.append("  Table 7 form, BHP window      n/a (open loop: no setpoints to track)")
    rows.append(f"  peak surge / swab             {summary['peak_surge_pa'] * p:+.2f} / "
                f"{summary['peak_swab_pa'] * p:+.2f} {bar}")
    rows += well_control.format_rows(summary, units)
    if "bhp_estimate_rmse_pa" in summary:
        rows += [
            f"  estimate - truth              mean error      RMSE  final bias (last {FINAL_WINDOW_S:.0f} s)",
            f"    BHP [{bar}]                  {summary['bhp_estimate_mean_error_pa'] * p:10.3f}  "
            f"{summary['bhp_estimate_rmse_pa'] * p:9.3f}  "
            f"{summary['bhp_estimate_final_bias_pa'] * p:10.3f}",
        ]
        for i, (mean, rmse, bias) in enumerate(zip(summary.get("friction_estimate_mean_error_pa", []),
                                                    summary.get("friction_estimate_rmse_pa", []),
                                                    summary.get("friction_estimate_final_bias_pa", []))):
            rows.append(f"    friction path {i + 2} [{bar}]     {mean * p:10.3f}  "
                        f"{rmse * p:9.3f}  {bias * p:10.3f}")
        if summary["string_flow_unobservable_s"] > 0.0:
            rows.append(f"  string flow unobservable      {summary['string_flow_unobservable_s']:.1f} s "
                        "(circulation off)")
    if "frame_late_max_s" in summary:
        skipped = (f", {summary['frames_skipped']:.0f} frames skipped"
                   if "frames_skipped" in summary else "")    # not counted before it was
        rows.append(f"  realtime frame lateness       p99 {summary['frame_late_p99_s'] * 1e3:.1f} ms, "
                    f"max {summary['frame_late_max_s'] * 1e3:.1f} ms{skipped} (plant frames "
                    "against their timer's schedule)")
    if "solves" in summary:
        rows.append(f"  NMPC solve time               median {summary['solve_time_median_s'] * 1e3:.1f} ms, "
                    f"p95 {summary['solve_time_p95_s'] * 1e3:.1f} ms, p99 {summary['solve_time_p99_s'] * 1e3:.1f} ms, "
                    f"max {summary['solve_time_max_s'] * 1e3:.1f} ms "
                    f"({summary['solves']} solves, {summary['fallbacks']} fallbacks; paper: 16.4 s)")
    if baseline:
        rows.append(f"  baseline peak surge / swab    {baseline['peak_surge_pa'] * p:+.2f} / "
                    f"{baseline['peak_swab_pa'] * p:+.2f} {bar}, BHP RMSE "
                    f"{baseline['bhp_rmse_pa'] * p:.3f} {bar}")
    return "\n".join(rows)


def plot(s: Series, out_dir: Path, units: Display = METRIC_DISPLAY) -> list[Path]:
    """PNG plots a drilling engineer expects (``units``: metric or field); returns their
    paths."""
    p, bar = units.factor("pressure"), units.symbol("pressure")
    q, lpm = units.factor("flow"), units.symbol("flow")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    t, bhp = s.get("bhp")
    tracking = tracks_setpoints(s)
    ref, band, target = references(s, t)
    paths = []

    def save(fig, name):
        path = out_dir / name
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)

    fig, ax = plt.subplots(figsize=(10, 4.5))
    tm, meas = s.get("bhp_meas")
    ax.plot(tm, meas * p, ".", ms=1, color="0.7", label="measured")
    ax.plot(t, bhp * p, lw=1.2, label="true")
    te, est = s.get("bhp_est")
    if len(te):
        ax.plot(te, est * p, lw=1, label="estimated")
    if tracking:
        ax.plot(t, ref * p, "k--", lw=1, label="reference")
        ax.fill_between(t, (ref - band) * p, (ref + band) * p, color="tab:green",
                        alpha=0.15, label="window")
    ax.set(xlabel="time [s]", ylabel=f"BHP [{bar}]", title="Bottom-hole pressure")
    ax.legend(loc="best", fontsize=8)
    save(fig, "bhp.png")

    fig, ax = plt.subplots(figsize=(10, 3.5))
    _, dp = s.get("choke_dp")
    ax.plot(t, dp * p)
    ax.set(xlabel="time [s]", ylabel=f"choke dp [{bar}]", title="Choke differential pressure")
    save(fig, "choke_dp.png")

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 5.5), sharex=True)
    _, pos = s.get("position")
    _, blk = s.get("block")
    a1.plot(t, pos, label="string position")
    a1.plot(t, blk, lw=0.8, label="block (drawworks)")
    if tracking:
        a1.plot(t, target, "k--", lw=0.8, label="target")
    a1.set(ylabel="position [m]")
    a1.legend(fontsize=8)
    _, vel = s.get("velocity")
    a2.plot(t, vel)
    t_limit, limit = s.get("trip_speed_limit")
    if len(limit):          # the trip-speed limit of the setpoints in force
        a2.step(t_limit, limit, where="post", color="r", ls=":", lw=0.8)
        a2.step(t_limit, -limit, where="post", color="r", ls=":", lw=0.8)
    a2.set(xlabel="time [s]", ylabel="string velocity [m/s]")
    save(fig, "block.png")

    fig, axes = plt.subplots(5, 1, figsize=(10, 9.5), sharex=True)
    _, qc = s.get("choke_flow")
    _, opening = s.get("choke_opening")
    _, bpp = s.get("bpp")
    _, spp = s.get("spp")
    commands = ((0, "cmd_block_ref", 1.0, "u_r command"),
                (1, "cmd_choke_flow", q, "PI flow reference"),
                (2, "cmd_choke_opening", 1.0, "manual opening command"),
                (3, "cmd_bpp", q, "command"), (4, "cmd_spp", p, "command"))
    axes[0].plot(t, pos, label="string position")
    axes[1].plot(t, qc * q, label="choke flow")
    axes[2].plot(t, opening, label="choke opening")
    axes[3].plot(t, bpp * q, label="back-pressure pump")
    axes[4].plot(t, spp * p, label="stand-pipe pressure")
    for row, key, factor, label in commands:
        tc, cmd = s.get(key)
        if len(cmd):
            axes[row].step(tc, cmd * factor, where="post", label=label)
    for ax, unit in zip(axes, ["m", lpm, "1", lpm, bar]):
        ax.set_ylabel(unit)
        ax.legend(fontsize=7, loc="best")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Inputs: block reference, choke flow and opening, back-pressure pump, "
                 "stand-pipe pressure")
    save(fig, "inputs.png")

    fig, ax = plt.subplots(figsize=(10, 4))
    _, fr = s.get("friction")
    tf, fe = s.get("friction_est")
    for i in range(fr.shape[1] if fr.ndim == 2 else 0):
        line, = ax.plot(t, fr[:, i] * p, lw=1, label=f"true path {i + 2}")
        if fe.ndim == 2 and len(fe):
            ax.plot(tf, fe[:, i] * p, "--", lw=1, color=line.get_color(),
                    label=f"estimated path {i + 2}")
    ax.set(xlabel="time [s]", ylabel=f"friction [{bar}]", title="Annular friction: estimated vs true")
    ax.legend(fontsize=7, ncol=2)
    save(fig, "friction.png")

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    if well_control.plot(s, a1, a2, units):
        save(fig, "well_control.png")
    else:
        plt.close(fig)
    return paths


def write_report(mcap_path: Path, out_dir: Path, name: str, baseline: dict | None = None,
                 units: Display = METRIC_DISPLAY):
    """Summary JSON, plots and the printed table for one recording: a tripping run's, or a
    drilling run's when the recording holds the drilling truth."""
    if drilling_report.holds_drilling(mcap_path):
        summary, plots, table = drilling_report.report(mcap_path, out_dir / "plots", name)
    else:
        series = load_series(mcap_path)
        summary = summarise(series, run_config_dir(out_dir))
        recorded = mcap_io.read_metadata(mcap_path, mcap_io.TRUTH_METADATA)
        summary["plant_mismatch"] = json.loads(recorded["truth"]) if recorded else None
        plots = plot(series, out_dir / "plots", units)
        sheet = trip_sheet_report.trip_sheet(mcap_path, load_rig(run_config_dir(out_dir)))
        table = format_table(name, summary, baseline, units, multi_stand=sheet is not None)
        t, bhp = series.get("bhp")
        if sheet is not None:                   # a multi-stand trip
            summary.update(sheet)
            table += "\n" + "\n".join(trip_sheet_report.format_sheet(sheet))
            ref, band, _ = references(series, t)
            by_phase = band_report.outside_band_by_phase(t, bhp, ref, band, series.floor_phases)
            summary["outside_band_by_phase"] = by_phase
            table += "\n" + "\n".join(band_report.format_rows(by_phase))
        errors = prediction_report.errors_over_run(series.predictions, t, bhp,
                                                   series.floor_phases)
        if errors:                              # an NMPC run
            summary["nmpc_prediction"] = errors
            table += "\n" + "\n".join(prediction_report.format_rows(errors))
    (out_dir / "summary.json").write_text(json.dumps(
        {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
         for k, v in summary.items()}, indent=2))
    return summary, plots, table
