"""What an OPC-UA write of a setpoint or of the automation level becomes, plain Python.

A setpoint write replaces one field of the setpoints in force and goes to the
supervisor's validating /set_setpoints service through the console's operator link
(``request``: drill_hmi.console.OperatorLink.request_setpoints), so the gateway
accepts exactly what the console accepts; the automation level goes out as the console
sends it (``set_level``: OperatorLink.set_level). The checks before that are the
console's (drill_hmi.console_state: numbers, signs, levels). Every outcome is a
``Outcome``: ``status`` None (Good) or the name of the OPC-UA Bad status, and the reason.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from drill_hmi import console_state as cs
from drill_gateway.opcua_names import Variable

BAD_OUT_OF_RANGE = "BadOutOfRange"              # refused here: not a value the field takes
BAD_TYPE_MISMATCH = "BadTypeMismatch"           # refused here: not a number / flag / text
BAD_NOT_ALLOWED = "BadRequestNotAllowed"        # refused by the supervisor (or unreachable)
BAD_USER_ACCESS_DENIED = "BadUserAccessDenied"  # refused here: the session's role may not write
# the console's form rules (sign, strictly positive), keyed by setpoint field
_FIELD_RULES = {spec.setpoint: spec for spec in cs.FORM_FIELDS.values()}


@dataclass(frozen=True)
class Outcome:
    status: str | None       # None: Good
    reason: str = ""

    @property
    def good(self) -> bool:
        return self.status is None

    def describe(self, what: str) -> str:
        if self.good:
            return f"accepted: {what}"
        return f"refused ({self.status}): {what}: {self.reason}"


class WrongType(cs.FormError):
    """Not a number where a number belongs, not a flag where a flag belongs."""


class NotReady(cs.FormError):
    """No setpoints in force yet to change one field of."""


def setpoint_request(active: dict | None, field: str, value) -> dict | None:
    """SI setpoints to request: those in force with ``field`` set to ``value``; None when
    that changes nothing. Raises WrongType, NotReady, or cs.FormError for a value outside
    the console's rules (finite, its sign rules)."""
    if active is None:
        raise NotReady("no setpoints in force yet (waiting for /setpoints from the supervisor)")
    if field in cs.BOOL_FIELDS:
        if not isinstance(value, bool):
            raise WrongType(f"{field}: expected true or false, got {value!r}")
        number = value
    else:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise WrongType(f"{field}: expected a number in SI units, got {value!r}")
        number = cs.parse_number(value, field)
        spec = _FIELD_RULES[field]
        if number < spec.minimum or (spec.strictly_above and number <= spec.minimum):
            relation = ">" if spec.strictly_above else ">="
            raise cs.FormError(f"{field}: {number:g} must be {relation} {spec.minimum:g}")
    if active.get(field) == number:
        return None
    request = {name: active.get(name, math.nan) for name in cs.SETPOINT_FIELDS}
    request[field] = number
    request["controller_enabled"] = bool(request["controller_enabled"])
    request["mud_pump_on"] = bool(request["mud_pump_on"])
    request["source"] = "opcua"
    return request


def write_setpoint(variable: Variable, value, active: dict | None,
                   request: Callable[[dict, str], dict]) -> Outcome:
    """Write ``value`` to setpoint ``variable``: checked here, then through ``request``
    (the validating service); a refusal changes nothing."""
    try:
        wanted = setpoint_request(active, variable.field, value)
    except WrongType as err:
        return Outcome(BAD_TYPE_MISMATCH, str(err))
    except NotReady as err:
        return Outcome(BAD_NOT_ALLOWED, str(err))
    except cs.FormError as err:
        return Outcome(BAD_OUT_OF_RANGE, str(err))
    if wanted is None:
        return Outcome(None, "no change")
    result = request(wanted, f"OPC-UA {variable.name}: {cs.describe_changes(active, wanted)}")
    return Outcome(None) if result["accepted"] else Outcome(BAD_NOT_ALLOWED, result["reason"])


def write_level(value, set_level: Callable[[str], dict]) -> Outcome:
    """Request automation level ``value`` (manual, advisory or closed_loop)."""
    try:
        level = cs.level_or_error(value if isinstance(value, str) else repr(value))
    except cs.FormError as err:
        return Outcome(BAD_OUT_OF_RANGE, str(err))
    result = set_level(level)
    return Outcome(None) if result["accepted"] else Outcome(BAD_NOT_ALLOWED, result["reason"])
