"""The report's well-control figures from a synthetic recording's series."""

from drill_analysis import well_control_report as wc
from drill_analysis.report import RecordedEvent, Series
from drill_core.config import KickDetection

DETECTOR = KickDetection(window_s=20.0, pressure_average_s=1.0, flow_threshold_m3s=3.3e-4,
                         confirm_s=5.0, stop_trip=True, pit_window_s=120.0)


def series(influx_from_s=None, alarms=(), estimate=None):
    s = Series()
    rate = 1.0e-3                                      # 60 L/min
    for k in range(1000):
        t = 0.1 * k
        influx = rate * max(t - influx_from_s, 0.0) if influx_from_s is not None else 0.0
        bhp = 6.85e7 - (2.0e5 if influx else 0.0)
        for key, value in (("bhp", bhp), ("pore", 6.84e7), ("fracture", 7.1e7),
                           ("pit_gain", influx), ("influx_volume", influx), ("loss_volume", 0.0)):
            s.add(key, t, value)
        if estimate is not None:
            s.add("influx_est", t, estimate(t))
    s.events += [RecordedEvent(a, "protection", "alarm", "kick_detected", 1.0e-3,
                               "kick detected: excess flow +60 L/min") for a in alarms]
    s.events.append(RecordedEvent(50.0, "rig", "formation", "pore_pressure", 6.84e7,
                                  "pore_pressure to 6.84e+07 Pa: starts"))
    return s


def test_a_detected_kick_gives_its_delay_and_volume_and_no_false_alarm():
    s = series(influx_from_s=50.0, alarms=(58.0,))
    t, bhp = s.get("bhp")
    out = wc.summarise(s, t, bhp, DETECTOR)
    d = out["detection"]["kick"]
    assert abs(d["onset_s"] - 50.1) < 1e-9 and abs(d["delay_s"] - 7.9) < 1e-9
    assert abs(d["volume_at_detection_m3"] - 8.0e-3) < 1e-9 and d["false_alarms"] == 0
    assert out["influx_volume_m3"] == out["pit_gain_max_m3"] > 0.049
    assert out["bhp_under_pore_s"] > 49.0 and abs(out["worst_underbalance_pa"] - 1.0e5) < 1e-6
    text = "\n".join(wc.format_rows(out))
    assert "kick detection" in text and "7.9 s after its onset, 8 L by then" in text
    assert "pore_pressure to 6.84e+07 Pa: starts" in text


def test_an_alarm_without_influx_is_a_false_one():
    s = series(alarms=(30.0,))
    t, bhp = s.get("bhp")
    d = wc.summarise(s, t, bhp, DETECTOR)["detection"]["kick"]
    assert d["false_alarms"] == 1 and d["delay_s"] is None and d["onset_s"] is None


def test_an_old_recording_has_no_well_control_figures():
    s = Series()
    for k in range(10):
        s.add("bhp", 0.1 * k, 6.85e7)
    t, bhp = s.get("bhp")
    assert wc.summarise(s, t, bhp, DETECTOR) == {} and wc.format_rows({}) == []


def test_the_influx_estimate_is_judged_with_the_detectors_threshold():
    """NMPC2's estimate over 20 L/min for 5 s raises its kick; a dip under it restarts the
    confirmation; a run without the estimate (all zero) has no estimate rows."""
    def estimate(t):
        if t < 55.0:
            return 0.0
        return 5.0e-4 if not 57.0 <= t < 58.0 else 1.0e-4     # 30 L/min, one dip
    s = series(influx_from_s=50.0, alarms=(58.0,), estimate=estimate)
    t, bhp = s.get("bhp")
    d = wc.summarise(s, t, bhp, DETECTOR)["detection"]
    assert abs(d["kick (estimate)"]["delay_s"] - (63.0 - 50.1)) < 1e-6
    assert d["kick (estimate)"]["false_alarms"] == 0 and d["losses (estimate)"]["delay_s"] is None
    s = series(influx_from_s=50.0, alarms=(58.0,), estimate=lambda t: 0.0)
    assert "kick (estimate)" not in wc.summarise(s, t, bhp, DETECTOR)["detection"]
    spurious = series(estimate=lambda t: -5.0e-4 if t > 10.0 else 0.0)
    d = wc.summarise(spurious, t, bhp, DETECTOR)["detection"]
    assert d["losses (estimate)"]["false_alarms"] == 1
