"""Operator actions of a scenario (its ``operator:`` list): what an operator presses at a
time - the emergency stop and its release, the automation level. The operator's setpoint
changes are the scenario's ``schedule`` (drill_core.scenario).

Plain data, validated like every scenario field. The process protection applies each
action at the first command at or after its time (drill_protection.protection_node), so a
fast-mode run presses it at the same stamp every time, and announces it on
/protection/events like the same action from the console.
"""
from __future__ import annotations

from dataclasses import dataclass

from drill_core.automation import AUTOMATION_LEVELS
from drill_core.schema import FieldError, param

ACTIONS = {
    "emergency_stop": "engage the emergency stop",
    "release": "release the emergency stop",
    "automation_level": "set the automation level to ``level``",
}


@dataclass(frozen=True)
class OperatorAction:
    """One entry of a scenario's ``operator`` list."""
    time_s: float = param("s", 0.0, 1.0e6)
    action: str = param(choices=tuple(ACTIONS))
    level: str = param(default="", doc="automation_level only: one of "
                                       + ", ".join(AUTOMATION_LEVELS))

    def validate(self) -> None:
        if self.action == "automation_level" and self.level not in AUTOMATION_LEVELS:
            raise FieldError("level", f"value {self.level!r} is not one of "
                                      f"{', '.join(AUTOMATION_LEVELS)} (action automation_level)")
        if self.action != "automation_level" and self.level:
            raise FieldError("level", f"action {self.action} takes no level")


class OperatorScript:
    """Hands out each action once, when its time has come, in time order."""

    def __init__(self, actions):
        self.pending = sorted(actions, key=lambda a: a.time_s)

    def due(self, time_s: float) -> list[OperatorAction]:
        """The actions at or before ``time_s`` [s] not handed out yet."""
        count = sum(1 for a in self.pending if a.time_s <= time_s + 1e-9)
        out, self.pending = self.pending[:count], self.pending[count:]
        return out
