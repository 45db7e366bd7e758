"""The well-control part of a run report: formation flows against the truth (influx,
losses, pit gain), time spent under the pore or over the fracture pressure in force, the
kick and loss detector's alarms and the estimator's influx estimate (NMPC2's bottom-influx
state, where the run estimates it) against the truth (delay, volume in at detection, false
alarms), and the event timeline (scenario events from /rig/events, protection alarms).
Plain Python over the report's Series (drill_analysis.report); SI in the summary, bar and
L at the display edge."""
from __future__ import annotations

import numpy as np

from drill_core.units import METRIC_DISPLAY, Display

TIMELINE_KINDS = {("rig", "fault"), ("rig", "formation"), ("protection", "alarm")}
# The protection's detector alarms (drill_protection.kick_detection), the truth volume they
# answer to, and the volume below which an alarm is a false one.
DETECTIONS = {"kick": ("kick_detected", "influx_volume"), "losses": ("losses_detected", "loss_volume")}
FALSE_ALARM_BELOW_M3 = 1.0e-3


def estimate_alarms(t, influx_m3s, threshold_m3s: float, confirm_s: float) -> dict:
    """The times the estimator's influx estimate would raise each alarm: beyond the
    detector's threshold (over it: kick, under minus it: losses) for its confirmation time,
    again after it has come back within the threshold."""
    out = {"kick": [], "losses": []}
    for kind, beyond in (("kick", influx_m3s > threshold_m3s),
                         ("losses", influx_m3s < -threshold_m3s)):
        since = None
        for time_s, over in zip(t, beyond):
            if not over:
                since = None
            elif since is None:
                since = time_s
            elif since is not False and time_s - since >= confirm_s:
                out[kind].append(float(time_s))
                since = False                     # raised: once until it comes back
    return out


def _judged(alarms, t, volume) -> dict:
    """The first true alarm's delay after the truth's onset, the volume by then, and the
    alarms raised before any such volume (false)."""
    at = [float(np.interp(a, t, volume)) for a in alarms]
    true = [(a, v) for a, v in zip(alarms, at) if v >= FALSE_ALARM_BELOW_M3]
    started = np.nonzero(volume > 0.0)[0]
    onset = float(t[started[0]]) if len(started) else None
    return {"onset_s": onset, "false_alarms": len(alarms) - len(true),
            "delay_s": true[0][0] - onset if true and onset is not None else None,
            "volume_at_detection_m3": true[0][1] if true else None}


def detections(s, t, config) -> dict:
    """Per kind: the protection's detector, and (``<kind> (estimate)``, where the run
    estimates the bottom influx) the estimator's influx estimate judged with the detector's
    threshold and confirmation time (``config``, drill_core.config.KickDetection)."""
    out = {}
    t_est, influx = s.get("influx_est")
    estimated = len(influx) > 0 and np.any(np.nan_to_num(influx) != 0.0)
    by_estimate = estimate_alarms(t_est, np.nan_to_num(influx), config.flow_threshold_m3s,
                                  config.confirm_s) if estimated else {}
    for kind, (code, key) in DETECTIONS.items():
        _, volume = s.get(key)
        alarms = [e.t_s for e in s.events if e.source == "protection" and e.code == code]
        out[kind] = _judged(alarms, t, volume)
        if estimated:
            out[f"{kind} (estimate)"] = _judged(by_estimate[kind], t, volume)
    return out

def summarise(s, t, bhp, detection_config) -> dict:
    """Formation figures of a run from its truth samples (empty for a recording made
    before the plant had a formation)."""
    _, pore = s.get("pore")
    _, fracture = s.get("fracture")
    if len(pore) != len(t) or not len(t) or not np.all(np.isfinite(pore)):
        return {}
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    _, pit_gain = s.get("pit_gain")
    _, influx = s.get("influx_volume")
    _, loss = s.get("loss_volume")
    return {
        "influx_volume_m3": float(influx[-1]),
        "loss_volume_m3": float(loss[-1]),
        "pit_gain_max_m3": float(np.max(pit_gain)),
        "pit_gain_final_m3": float(pit_gain[-1]),
        "bhp_under_pore_s": float(np.count_nonzero(bhp < pore) * dt),
        "bhp_over_fracture_s": float(np.count_nonzero(bhp > fracture) * dt),
        "worst_underbalance_pa": float(max(np.max(pore - bhp), 0.0)),
        "worst_overbalance_over_fracture_pa": float(max(np.max(bhp - fracture), 0.0)),
        "events": [e.as_dict() for e in s.events if (e.source, e.kind) in TIMELINE_KINDS],
        "detection": detections(s, t, detection_config),
    }


def format_rows(summary: dict, units: Display = METRIC_DISPLAY) -> list[str]:
    """Table rows for the printed report (none without formation figures; ``units``:
    metric or field)."""
    if "influx_volume_m3" not in summary:
        return []
    p, bar = units.factor("pressure"), units.symbol("pressure")
    v, litre = units.factor("gain"), units.symbol("gain")
    digits = 0 if litre == "L" else 1          # whole litres, tenths of a barrel
    rows = [
        f"  formation                     influx {summary['influx_volume_m3'] * v:.{digits}f} {litre}, "
        f"losses {summary['loss_volume_m3'] * v:.{digits}f} {litre}, pit gain max "
        f"{summary['pit_gain_max_m3'] * v:+.{digits}f} {litre} (final "
        f"{summary['pit_gain_final_m3'] * v:+.{digits}f} {litre})",
        f"  BHP under pore pressure       {summary['bhp_under_pore_s']:.1f} s (worst "
        f"{summary['worst_underbalance_pa'] * p:.2f} {bar} under), over fracture "
        f"{summary['bhp_over_fracture_s']:.1f} s",
    ]
    for kind, d in summary["detection"].items():
        if d["onset_s"] is None and not d["false_alarms"]:
            continue
        found = "not detected" if d["delay_s"] is None else \
            f"detected {d['delay_s']:.1f} s after its onset, " \
            f"{d['volume_at_detection_m3'] * v:.{digits}f} {litre} by then"
        rows.append(f"  {kind + ' detection':<30}{found}; {d['false_alarms']} false alarms")
    events = summary["events"]
    if events:
        rows.append(f"  event timeline                {len(events)} events")
        rows += [f"    t = {e['t_s']:7.1f} s  {e['source']:<10} {e['code']:<18} {e['text']}"
                 for e in events]
    return rows


def plot(s, ax_pressure, ax_volume, units: Display = METRIC_DISPLAY) -> bool:
    """BHP against the window in force, and pit gain (true, measured) with the influx and
    loss volumes; False (nothing drawn) for a recording without them."""
    t, bhp = s.get("bhp")
    _, pore = s.get("pore")
    if len(pore) != len(t) or not len(t) or not np.all(np.isfinite(pore)):
        return False
    _, fracture = s.get("fracture")
    p, bar = units.factor("pressure"), units.symbol("pressure")
    v, litre = units.factor("gain"), units.symbol("gain")
    ax_pressure.plot(t, bhp * p, lw=1.2, label="BHP (true)")
    ax_pressure.plot(t, pore * p, "r-", lw=0.9, label="pore pressure")
    ax_pressure.plot(t, fracture * p, "m-", lw=0.9, label="fracture pressure")
    ax_pressure.set(ylabel=f"pressure [{bar}]", title="Bottom-hole pressure in the formation window")
    for e in s.events:
        if (e.source, e.kind) in TIMELINE_KINDS:
            ax_pressure.axvline(e.t_s, color="0.5", ls=":", lw=0.8)
    ax_pressure.legend(fontsize=7, loc="best")
    tm, pit = s.get("pit_meas")
    if len(pit):
        ax_volume.plot(tm, (pit - pit[0]) * v, ".", ms=1, color="0.7",
                       label="pit volume change (measured)")
    for key, label in (("pit_gain", "pit gain (true)"), ("influx_volume", "influx"),
                       ("loss_volume", "losses")):
        _, volume = s.get(key)
        ax_volume.plot(t, volume * v, lw=1, label=label)
    ax_volume.set(xlabel="time [s]", ylabel=f"volume [{litre}]")
    ax_volume.legend(fontsize=7, loc="best")
    return True
