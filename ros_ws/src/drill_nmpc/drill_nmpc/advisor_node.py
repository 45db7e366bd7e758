"""The skeleton the advisor nodes share (``nmpc``, ``automated_mpd``, ``baseline``): the
node context, the sample gate, the status reporter, the setpoint book and its publishing
(the latched /setpoints, /operator/events) and the command publisher. A subclass decides
what to command; docs/design.md §6 and §10."""
from __future__ import annotations

from drill_msgs.msg import OperatorEvent, RigCommand, Setpoints

from drill_core.ros import topics
from drill_core.ros.context import load_context
from drill_core.ros.node import RigNode
from drill_core.ros.sampling import SampleGate
from drill_core.ros.stamps import from_ns, seconds_to_ns
from drill_core.ros.status import StatusReporter
from drill_core.scenario import initial_setpoints
from drill_nmpc.setpoint_book import Event, SetpointBook
from drill_nmpc.setpoint_messages import to_msg
from drill_nmpc.setpoint_validation import Envelope


class AdvisorNode(RigNode):
    def __init__(self, name: str, status_topic: str | None = None, **node_options):
        super().__init__(name, **node_options)
        self.ctx = load_context(self)
        self.exit_code = 0
        cfg, scenario = self.ctx.config, self.ctx.scenario
        self.gate = SampleGate(seconds_to_ns(cfg.nmpc.sample_time_s), self.ctx.fast)
        self.status = StatusReporter(self, self.ctx.mode, topic=status_topic)
        self.book = SetpointBook(scenario, initial_setpoints(cfg, scenario),
                                 Envelope.from_config(cfg, self.ctx.well_model.geometry))
        self.cmd_pub = self.create_publisher(RigCommand, topics.COMMAND, topics.RELIABLE)
        self.sp_pub = self.create_publisher(Setpoints, topics.SETPOINTS, topics.LATCHED)
        self.event_pub = self.create_publisher(OperatorEvent, topics.OPERATOR_EVENTS, topics.RELIABLE)

    def follow_schedule(self, stamp_ns: int) -> None:
        """Apply the schedule entries due at this stamp; a refused entry is a node error."""
        events = self.book.advance(self.gate.scenario_time_s(stamp_ns))
        for e in events:
            if not e.accepted:
                self.status.error(e.text)
        self.publish_events(events, stamp_ns)

    def publish_events(self, events: list[Event], stamp_ns: int, source: str = "scenario") -> None:
        """The book's events on /operator/events, then its setpoints if they changed."""
        for e in events:
            msg = OperatorEvent(kind=e.kind, text=e.text, accepted=e.accepted)
            msg.header.stamp = from_ns(stamp_ns)
            self.event_pub.publish(msg)
        if self.book.changed:
            self.sp_pub.publish(to_msg(self.book.active, stamp_ns, source))
            self.book.changed = False

    def publish_command(self, cmd: RigCommand, stamp_ns: int) -> None:
        cmd.header.stamp = from_ns(stamp_ns)
        self.cmd_pub.publish(cmd)
