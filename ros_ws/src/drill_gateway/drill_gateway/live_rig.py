"""A gateway's subscriptions to a live run's sensor sample and the actuator frames its
well-log channels read (drill_bag.well_log.LiveRig), best-effort keep-last like every
display subscription, so a gateway never holds up the graph."""
from __future__ import annotations

from pathlib import Path

from drill_msgs.msg import ActuatorFrame, RigMeasurement

from drill_bag.well_log import FRAME_ACTUATORS, LiveRig
from drill_core.config import Well, load_section
from drill_hmi import console
from drill_ros import topics


def live_rig(config_dir: str) -> LiveRig:
    """The live view of a run configured in ``config_dir`` (its well.yaml)."""
    return LiveRig(load_section(Well, Path(config_dir) / "well.yaml"))


def follow(node, live: LiveRig, on_measurement=None) -> None:
    """Feed ``live`` from ``node``'s subscriptions; ``on_measurement(msg)`` after each
    sensor sample is taken in."""
    def measured(msg: RigMeasurement) -> None:
        live.on_measurement(msg)
        if on_measurement is not None:
            on_measurement(msg)
    node.create_subscription(RigMeasurement, topics.MEASUREMENT, measured, console.DISPLAY)
    for actuator in FRAME_ACTUATORS:
        node.create_subscription(ActuatorFrame, topics.actuator_frame(actuator),
                                 lambda msg, a=actuator: live.on_frame(a, msg), console.DISPLAY)
