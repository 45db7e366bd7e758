"""Scenario events: validated against their table, with errors that name the key."""
import math

import pytest
import yaml

from drill_core.config import ConfigError
from drill_core.events import EVENT_KINDS, ScenarioEvent, of_owner
from drill_core.rig_root import rig_root
from drill_core.scenario import load_scenario
from drill_core.schema import build

ROOT = rig_root()


def event(**fields):
    return build(ScenarioEvent, fields, "<test>", "events[0]")


def test_every_kind_builds_from_its_own_table_entry():
    for kind, spec in EVENT_KINDS.items():
        fields = {"time_s": 10.0, "kind": kind}
        if spec.targets:
            fields["target"] = spec.targets[0]
        if spec.value is not None:
            fields["value"] = min(max(0.5, spec.value[1]), spec.value[2])
        if spec.timing == "span":
            fields["duration_s"] = 5.0
        e = event(**fields)
        assert e.describe().startswith(spec.targets[0] if spec.targets else kind)


@pytest.mark.parametrize("fields, words", [
    ({"kind": "dropout", "target": "bhp", "duration_s": 5.0}, ("target", "'bhp'", "bhp_pa")),
    ({"kind": "dropout", "target": "bhp_pa"}, ("duration_s", "missing", "dropout")),
    ({"kind": "nan", "target": "bhp_pa", "duration_s": 2.0}, ("duration_s", "one sample")),
    ({"kind": "pore_pressure", "value": 6.9e7, "target": "bhp_pa"}, ("target", "no target")),
    ({"kind": "pore_pressure"}, ("value", "missing", "[0, 5e+08] Pa")),
    ({"kind": "choke_plugging", "value": 1.5}, ("value", "1.5", "[0, 1] (event")),
    ({"kind": "trip", "target": "choke"}, ("target", "'choke'", "bpp, mud_pump")),
    ({"kind": "stuck", "target": "choke", "value": 0.3}, ("value", "takes no value")),
    ({"kind": "leak", "target": "choke"}, ("kind", "'leak'", "dropout")),
])
def test_a_bad_event_names_the_key_and_what_is_allowed(fields, words):
    with pytest.raises(ConfigError) as info:
        event(time_s=3.0, **fields)
    for word in words:
        assert word in str(info.value), (word, str(info.value))
    assert "events[0]" in str(info.value)


def test_span_and_until_events_act_over_their_time():
    dropout = event(time_s=10.0, kind="dropout", target="bhp_pa", duration_s=5.0)
    assert not dropout.active(9.9) and dropout.active(10.0) and dropout.active(14.9)
    assert not dropout.active(15.0)
    trip = event(time_s=10.0, kind="trip", target="bpp")            # to the end of the run
    assert trip.end_s == math.inf and trip.active(1.0e5)
    assert of_owner((dropout, trip), "actuator", "bpp") == (trip,)
    assert of_owner((dropout, trip), "plant") == (dropout,)


def test_a_scenario_refuses_an_event_after_its_end(tmp_path):
    data = yaml.safe_load((ROOT / "config" / "scenarios" / "case2.yaml").read_text())
    data["events"] = [{"time_s": 700.0, "kind": "trip", "target": "bpp"}]
    path = tmp_path / "late.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    assert "events[0].time_s" in str(info.value) and "duration_s 600" in str(info.value)
