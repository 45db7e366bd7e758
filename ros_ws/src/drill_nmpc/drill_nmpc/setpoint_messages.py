"""Setpoints in force (drill_core.scenario.ActiveSetpoints) to and from drill_msgs/Setpoints,
shared by the advisors that publish them on the latched /setpoints topic."""
from __future__ import annotations

import dataclasses
import math

from drill_msgs.msg import Setpoints

from drill_ros.stamps import from_ns
from drill_core.scenario import ActiveSetpoints
from drill_nmpc.setpoint_validation import NUMERIC_FIELDS


def merge_request(active: ActiveSetpoints, msg: Setpoints) -> ActiveSetpoints:
    """Requested setpoints over the ones in force: a NaN numeric field keeps its value."""
    changes = {}
    for name in NUMERIC_FIELDS:
        value = float(getattr(msg, name))
        if not math.isnan(value):
            changes[name] = value
    changes["controller_enabled"] = bool(msg.controller_enabled)
    changes["mud_pump_on"] = bool(msg.mud_pump_on)
    return dataclasses.replace(active, **changes)


def to_msg(sp: ActiveSetpoints, stamp_ns: int, source: str) -> Setpoints:
    msg = Setpoints()
    msg.header.stamp = from_ns(stamp_ns)
    for name in NUMERIC_FIELDS:
        setattr(msg, name, float(getattr(sp, name)))
    msg.controller_enabled = bool(sp.controller_enabled)
    msg.mud_pump_on = bool(sp.mud_pump_on)
    msg.source = source
    return msg
