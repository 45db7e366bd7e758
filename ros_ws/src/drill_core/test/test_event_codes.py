"""The event-code table: every scenario event kind has its start and end codes under its
category, every code's kind is one an OperatorEvent carries, and a Notice refuses a code
outside the table."""
import math

import pytest

from drill_core.event_codes import ENDED, EVENT_CODES, Notice, markdown_table, scenario_notice
from drill_core.events import EVENT_KINDS, ScenarioEvent
from drill_core.rig_root import rig_root

KINDS = {"alarm", "clamp", "refusal", "mode", "emergency_stop", "setpoint", "acknowledge",
         "fault", "formation"}


def test_every_code_is_filed_under_a_known_kind_with_a_unit_or_none():
    assert {c.kind for c in EVENT_CODES.values()} <= KINDS
    assert all(isinstance(c.unit, str) and c.doc for c in EVENT_CODES.values())


def test_each_scenario_event_kind_starts_and_ends_under_its_category():
    for kind, spec in EVENT_KINDS.items():
        assert EVENT_CODES[kind].kind == EVENT_CODES[kind + ENDED].kind == spec.category


def test_a_scenario_event_is_announced_with_its_kind_and_value():
    event = ScenarioEvent(time_s=90.0, kind="pore_pressure", value=6.9e7)
    start, end = scenario_notice(event, False), scenario_notice(event, True)
    assert (start.code, start.kind, start.value) == ("pore_pressure", "formation", 6.9e7)
    assert end.code == "pore_pressure_ended" and end.text.endswith(": ends")
    assert math.isnan(scenario_notice(ScenarioEvent(time_s=1.0, kind="trip", target="bpp"),
                                      False).value)


def test_a_notice_with_a_code_outside_the_table_is_refused():
    assert Notice("kick_detected", "kick detected", 2.0e-3).kind == "alarm"
    with pytest.raises(ValueError, match="kick detected"):
        Notice("kick detected", "prose is not a code")


def test_the_documented_table_is_the_declared_one():
    doc = (rig_root() / "docs" / "events.md").read_text(encoding="utf-8")
    assert markdown_table() in doc, "regenerate it: python -m drill_core.event_codes"
