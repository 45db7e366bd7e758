"""A scenario's operator actions: validated with errors that name the key, read from the
scenario file, and handed out once each when their time has come."""

import pytest
import yaml

from drill_core.config import ConfigError
from drill_core.operator_actions import OperatorAction, OperatorScript
from drill_core.rig_root import rig_root
from drill_core.scenario import load_scenario
from drill_core.schema import build

ROOT = rig_root()


def action(**fields):
    return build(OperatorAction, fields, "<test>", "operator[0]")


@pytest.mark.parametrize("fields, words", [
    ({"action": "brake"}, ("action", "'brake'", "emergency_stop")),
    ({"action": "automation_level"}, ("level", "''", "manual, advisory, closed_loop")),
    ({"action": "automation_level", "level": "auto"}, ("level", "'auto'")),
    ({"action": "release", "level": "manual"}, ("level", "takes no level")),
    ({"action": "emergency_stop", "time_s": -1.0}, ("time_s",)),
])
def test_a_bad_action_names_the_key_and_what_is_allowed(fields, words):
    with pytest.raises(ConfigError) as info:
        action(**{"time_s": 3.0, **fields})
    for word in words:
        assert word in str(info.value), (word, str(info.value))
    assert "operator[0]" in str(info.value)


def test_the_script_hands_out_each_action_once_in_time_order():
    script = OperatorScript([action(time_s=20.0, action="release"),
                             action(time_s=10.0, action="emergency_stop"),
                             action(time_s=20.0, action="automation_level", level="manual")])
    assert script.due(9.9) == []
    assert [a.action for a in script.due(10.0)] == ["emergency_stop"]
    assert script.due(15.0) == []
    assert [a.action for a in script.due(25.0)] == ["release", "automation_level"]
    assert script.due(1.0e6) == []


def test_a_scenario_reads_its_actions_and_refuses_one_after_its_end(tmp_path):
    data = yaml.safe_load((ROOT / "config" / "scenarios" / "case2.yaml").read_text())
    data["operator"] = [{"time_s": 40.0, "action": "emergency_stop"},
                        {"time_s": 50.0, "action": "release"}]
    path = tmp_path / "pressed.yaml"
    path.write_text(yaml.safe_dump(data))
    scenario, _ = load_scenario(path)
    assert [(a.time_s, a.action) for a in scenario.operator] == [(40.0, "emergency_stop"),
                                                                 (50.0, "release")]
    data["operator"].append({"time_s": 600.0, "action": "release"})
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    assert "operator[2].time_s" in str(info.value) and "duration_s 600" in str(info.value)
