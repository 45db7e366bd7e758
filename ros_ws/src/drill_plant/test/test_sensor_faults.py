"""Sensor faults on the plant's samples: each acts on its channel only, when it should."""
import math
from dataclasses import dataclass

import numpy as np
import pytest

from drill_core.events import ScenarioEvent
from drill_plant.sensor_faults import SensorFaults


@dataclass(frozen=True)
class Sample:
    bhp_pa: float
    choke_dp_pa: float


def run(events, seconds=10.0, period=0.1, seed=1):
    faults = SensorFaults(tuple(events), seed)
    out = []
    for k in range(int(round(seconds / period))):
        t = k * period
        out.append((t, faults.apply(t, Sample(bhp_pa=6.85e7 + 100.0 * k, choke_dp_pa=2.0e6))))
    return out


def bhp(rows):
    return np.array([r[1].bhp_pa for r in rows])


def test_no_event_no_change_and_other_channels_untouched():
    dropout = ScenarioEvent(2.0, "dropout", "bhp_pa", duration_s=1.0)
    rows = run([dropout])
    assert all(r[1].choke_dp_pa == 2.0e6 for r in rows)
    values = bhp(rows)
    assert np.isnan(values[20:30]).all() and np.isfinite(values[:20]).all() \
        and np.isfinite(values[30:]).all()
    assert values[30] == 6.85e7 + 100.0 * 30                     # back to the live sensor
    assert dropout.describe() == "bhp_pa dropout for 1 s"          # as /rig/events names it


def test_frozen_holds_the_last_value_before_the_fault():
    values = bhp(run([ScenarioEvent(2.0, "frozen", "bhp_pa", duration_s=1.0)]))
    assert (values[20:30] == 6.85e7 + 100.0 * 19).all() and values[30] == 6.85e7 + 3000.0


def test_bias_and_drift_add_their_value():
    values = bhp(run([ScenarioEvent(1.0, "bias", "bhp_pa", 5.0e5, 1.0),
                      ScenarioEvent(5.0, "drift", "bhp_pa", 1.0e5, 2.0)]))
    clean = 6.85e7 + 100.0 * np.arange(100)
    assert np.allclose(values[10:20] - clean[10:20], 5.0e5)
    assert np.allclose(values[50:70] - clean[50:70], 1.0e5 * 0.1 * np.arange(20))
    assert np.array_equal(values[70:], clean[70:])


def test_single_samples_act_once_at_the_first_sample_due():
    rows = run([ScenarioEvent(1.05, "nan", "bhp_pa"), ScenarioEvent(2.0, "inf", "bhp_pa"),
                ScenarioEvent(3.0, "spike", "bhp_pa", 2.0e6)])
    values = bhp(rows)
    assert math.isnan(values[11]) and np.isfinite(values[10]) and np.isfinite(values[12])
    assert values[20] == math.inf and np.isfinite(values[21])
    assert values[30] == 6.85e7 + 3000.0 + 2.0e6 and values[31] == 6.85e7 + 3100.0
    assert sum(1 for v in values if not math.isfinite(v)) == 2


def test_noise_burst_is_seeded_and_has_its_size():
    event = [ScenarioEvent(0.0, "noise_burst", "bhp_pa", 1.0e5, 100.0)]
    a, b = bhp(run(event, 100.0)), bhp(run(event, 100.0))
    assert np.array_equal(a, b)
    noise = a - (6.85e7 + 100.0 * np.arange(1000))
    assert noise.std() == pytest.approx(1.0e5, rel=0.1)


def test_the_event_channels_are_the_plants_measured_channels():
    import dataclasses as dc

    from drill_core.events import SENSOR_CHANNELS
    from drill_plant.simulator import Measurement
    assert set(SENSOR_CHANNELS) == {f.name for f in dc.fields(Measurement)} - {"string_flow_valid"}
