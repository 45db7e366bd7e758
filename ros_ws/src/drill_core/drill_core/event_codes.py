"""The rig's event codes: one table of what an OperatorEvent's ``code`` means, the kind
(category) it is filed under and the SI unit of its ``value``. Producers build a
:class:`Notice` by code; the report, the console, the studies and the gateways match
codes, never the text, which is for people.

A scenario event (drill_core.events) is announced on /rig/events under its own kind as
code when it starts and ``<kind>_ended`` when a lasting one ends, its value the event's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drill_core.events import EVENT_KINDS


@dataclass(frozen=True)
class EventCode:
    """What one code means: the OperatorEvent kind it goes out as and its value's unit."""
    kind: str     # "alarm", "clamp", "refusal", "mode", "emergency_stop", "setpoint",
                  # "acknowledge", "fault" or "formation"
    unit: str     # the SI unit of the event's value ("" when it carries none: NaN)
    doc: str


_PROTECTION = {
    "kick_detected": EventCode("alarm", "m^3", "the flow balance's kick alarm is raised; "
                                               "value: the volume in since it began"),
    "losses_detected": EventCode("alarm", "m^3", "the flow balance's losses alarm is raised; "
                                                 "value: the volume lost since it began"),
    "kick_cleared": EventCode("alarm", "", "the kick alarm is cleared"),
    "losses_cleared": EventCode("alarm", "", "the losses alarm is cleared"),
    "window_narrowed": EventCode("alarm", "Pa", "the well-control response moves an edge of "
                                                "the BHP window; value: the edge moved"),
    "circulation_lost": EventCode("alarm", "", "circulation lost: the mud pump is asked for, "
                                               "the string-flow meter reads nothing"),
    "circulation_restored": EventCode("alarm", "", "circulation is back"),
    "gauge_frozen": EventCode("alarm", "", "a gauge repeats its value: the protection reads it "
                                           "as a dropout until it moves"),
    "gauge_live": EventCode("alarm", "", "a gauge read as frozen moves again"),
    "window_exit": EventCode("alarm", "Pa", "BHP left the pore/fracture window; value: BHP"),
    "window_return": EventCode("alarm", "Pa", "BHP is back inside the window; value: BHP"),
    "non_finite_request": EventCode("clamp", "", "a non-finite command: the last one held"),
    "non_finite_manual_choke": EventCode("clamp", "", "a non-finite manual choke opening: the "
                                                      "last choke mode held"),
    "estop_hold": EventCode("clamp", "Pa", "emergency stop in force: the advisor's command not "
                                           "applied; value: the BHP held"),
    "protective_stop": EventCode("clamp", "Pa", "circulation lost and the choke stuck: the "
                                                "brake set, the back-pressure pump at its "
                                                "maximum, the choke's BHP loop; value: its BHP"),
    "level_hold": EventCode("clamp", "", "the automation level keeps the advisor's command off"),
    "non_finite_dp_setpoint": EventCode("clamp", "", "a non-finite choke dp set-point: the choke "
                                                     "on its flow reference"),
    "dp_setpoint_unread": EventCode("clamp", "", "no usable choke-dp reading: the choke on its "
                                                 "flow controller instead of a dp set-point"),
    "well_control_hold": EventCode("clamp", "Pa", "the well-control response holds the choke; "
                                                  "value: the BHP it holds"),
    "window_guard": EventCode("clamp", "Pa", "BHP past a window limit, or heading past it "
                                             "within the guard's lead: the choke and the "
                                             "back-pressure pump hold back; value: the "
                                             "reading out (the BHP while it is, else the BHP "
                                             "without friction or the one heading out)"),
    "machine_limit": EventCode("clamp", "", "an input cut to its machine range or rate"),
    "pump_trip_floor": EventCode("clamp", "m^3/s", "the pump-trip response's back-pressure pump "
                                                   "floor; value: the floor"),
    "pump_trip_response": EventCode("clamp", "", "the mud pump has tripped: the response acts"),
    "speed_clamp": EventCode("clamp", "m/s", "the block's speed cut (surge/swab model, operator "
                                             "limit, drawworks); value: the speed allowed"),
    "lost_circulation_hold": EventCode("clamp", "m", "circulation lost while the string is "
                                                    "pulled faster than the swab limit without "
                                                    "friction: the block reference held at the "
                                                    "string, the back-pressure pump commanded "
                                                    "to its maximum; value: the reference"),
    "drawworks_not_following": EventCode("clamp", "m", "the block did not follow its reference "
                                                      "(a stuck drawworks): the reference held at "
                                                      "the string; value: the reference"),
    "drawworks_range": EventCode("clamp", "m", "the block reference held inside the drawworks' "
                                               "range; value: the reference"),
    "estop_engaged": EventCode("emergency_stop", "", "the emergency stop is engaged"),
    "estop_released": EventCode("emergency_stop", "", "the emergency stop is released"),
    "automation_level": EventCode("mode", "", "the automation level in force changed"),
    "level_refused": EventCode("refusal", "", "an unknown automation level was refused"),
}
_OPERATOR = {      # the operator link (console, terminal CLI, gateways) and the advisor's book
    "operator_setpoints_accepted": EventCode("setpoint", "", "the link's setpoint request was "
                                                             "accepted by the advisor"),
    "operator_setpoints_refused": EventCode("refusal", "", "the link's setpoint request was refused "
                                                           "(or went unanswered)"),
    "setpoints_accepted": EventCode("setpoint", "Pa", "a setpoint request was accepted; value: "
                                                      "the BHP reference"),
    "setpoints_refused": EventCode("refusal", "", "a setpoint request was refused"),
    "level_requested": EventCode("mode", "", "an automation level was requested"),
    "estop_requested": EventCode("emergency_stop", "", "the emergency stop was pressed"),
    "estop_release_requested": EventCode("emergency_stop", "", "its release was requested"),
    "acknowledged": EventCode("acknowledge", "", "alarms were acknowledged"),
    "request_refused": EventCode("refusal", "", "an operator input was not turned into a "
                                                "request (a bad form, no token, no write role)"),
    "schedule_setpoints": EventCode("setpoint", "Pa", "the scenario's schedule set the setpoints; "
                                                      "value: the BHP reference"),
    "schedule_refused": EventCode("refusal", "", "a schedule entry was refused"),
    "well_control_setpoints": EventCode("setpoint", "Pa", "the protection's well-control target "
                                                          "became the setpoints; value: the BHP reference"),
    "well_control_refused": EventCode("refusal", "", "the protection's well-control target was refused"),
}
_TRIP = {         # the trip sheet (drill_core.tripping.trip_sheet)
    "trip_tank_gain": EventCode("alarm", "m^3", "the trip tank shows the well giving back more "
                                                "than the steel tripped: a swabbed influx; "
                                                "value: the running gain"),
    "trip_tank_loss": EventCode("alarm", "m^3", "the trip tank shows the well taking more than "
                                                "the steel tripped: losses; value: the running gain"),
}
ENDED = "_ended"
_RIG = {code: EventCode(spec.category, spec.value[0] if spec.value else "", doc)
        for kind, spec in EVENT_KINDS.items()
        for code, doc in ((kind, f"scenario event: {spec.doc}"),
                          (kind + ENDED, f"the end of a lasting {kind} event"))}
EVENT_CODES: dict[str, EventCode] = {**_PROTECTION, **_TRIP, **_OPERATOR, **_RIG}


@dataclass(frozen=True)
class Notice:
    """One event as a producer emits it: a code of EVENT_CODES, a text for people, and the
    code's value (SI, NaN where it carries none)."""
    code: str
    text: str
    value: float = math.nan

    def __post_init__(self):
        if self.code not in EVENT_CODES:
            raise ValueError(f"event code {self.code!r} is not in drill_core.event_codes.EVENT_CODES")

    @property
    def kind(self) -> str:
        return EVENT_CODES[self.code].kind


def scenario_notice(event, ended: bool) -> Notice:
    """The announcement of a scenario event (drill_core.events.ScenarioEvent) starting or,
    ``ended``, ending: its kind as code, its value."""
    return Notice(event.kind + (ENDED if ended else ""),
                  f"{event.describe()}: {'ends' if ended else 'starts'}", event.value)


def markdown_table() -> str:
    """The code table for docs/events.md (``python -m drill_core.event_codes`` prints it)."""
    rows = ["| code | kind | value | meaning |", "| --- | --- | --- | --- |"]
    rows += [f"| `{code}` | {c.kind} | {c.unit or '–'} | {c.doc} |" for code, c in EVENT_CODES.items()]
    return "\n".join(rows)


if __name__ == "__main__":
    print(markdown_table())
