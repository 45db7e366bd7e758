"""The skeleton the advisor nodes share (``nmpc``, ``automated_mpd``, ``baseline``): the
node context, the sample gate, the status reporter, the setpoint book and its publishing
(the latched /setpoints, /operator/events), the command publisher, and the protection's
answer. A subclass decides what to command; docs/design.md §6 and §10.

A sample runs once its inputs are in: the subclass's own (``inputs_ready``) and, in fast
mode, the protection's machine command answering this advisor's last command. That
answer carries the BHP window and reference in force; when a kick or losses answer
narrowed the window past the advisor's reference, the book takes the protection's target
(drill_protection.well_control) before the sample's schedule entries; its trip-speed
limits and the block reference it applied are kept for the subclass to plan with
(``speed_limits_mps``, ``applied_block_m``). Realtime: the latest machine command. On a
multi-stand trip (the scenario's ``trip:``) a sample also waits for the rig floor's command
stamped with it (``floor_at``)."""
from __future__ import annotations

from collections import deque
from dataclasses import asdict

from drill_msgs.msg import OperatorEvent, RigCommand, RigFloor, Setpoints

from drill_ros import topics
from drill_ros.context import load_context
from drill_ros.events import event_message
from drill_ros.floor import floor_command
from drill_ros.inbox import StampedInbox
from drill_ros.node import RigNode
from drill_ros.sampling import SampleGate
from drill_ros.stamps import from_ns, seconds_to_ns, to_ns
from drill_ros.status import StatusReporter
from drill_core.scenario import initial_setpoints
from drill_nmpc.advisor_ticks import AdvisorCommand, StartInputs, SupervisorRequest
from drill_nmpc.setpoint_book import Event, SetpointBook
from drill_nmpc.setpoint_messages import to_msg
from drill_nmpc.setpoint_validation import Envelope

SENT_KEPT = 10          # commands whose BHP reference is remembered (realtime answers lag)


class AdvisorNode(RigNode):
    def __init__(self, name: str, status_topic: str | None = None, **node_options):
        super().__init__(name, **node_options)
        self.ctx = load_context(self)
        self.exit_code = 0
        cfg, scenario = self.ctx.config, self.ctx.scenario
        self.gate = SampleGate(seconds_to_ns(cfg.nmpc.sample_time_s), self.ctx.fast)
        self.status = StatusReporter(self, self.ctx.mode, topic=status_topic)
        self.start = StartInputs.of(scenario.initial, self.ctx.operating_point)
        self.book = SetpointBook(scenario, initial_setpoints(cfg, scenario),
                                 Envelope.from_config(cfg, self.ctx.well_model.geometry))
        self.cmd_pub = self.create_publisher(RigCommand, topics.COMMAND, topics.RELIABLE)
        self.sp_pub = self.create_publisher(Setpoints, topics.SETPOINTS, topics.LATCHED)
        self.event_pub = self.create_publisher(OperatorEvent, topics.OPERATOR_EVENTS, topics.EVENT_LOG)
        self.sent_bhp_ref_pa: dict[int, float] = {}  # BHP reference [Pa] of our recent
                                                     # commands, by stamp
        self.machine: dict[int, RigCommand] = {}     # the protection's commands by stamp
        self.pending: deque = deque()     # (input, stamp) of the samples waiting, in order
        # from the protection's last answer: its trip-speed limits running in and pulling
        # out [m/s] and the block reference it applied [m] (NaN: no answer yet)
        self.speed_limits_mps = (float("nan"), float("nan"))
        self.applied_block_m = float("nan")
        self.create_subscription(RigCommand, topics.MACHINE_COMMAND, self._on_machine_command,
                                 topics.RELIABLE)
        self.trip = scenario.trip                      # a multi-stand trip: the rig floor's
        self.floor = StampedInbox(("floor",))
        if self.trip is not None:
            self.create_subscription(RigFloor, topics.FLOOR, self._on_floor, topics.RELIABLE)

    def _on_floor(self, msg: RigFloor) -> None:
        self.floor.put("floor", msg)
        self.try_pending()

    def floor_at(self, stamp_ns: int):
        """The rig floor's command stamped ``stamp_ns`` (drill_core.tripping.rig_floor;
        None: no multi-stand trip)."""
        return None if self.trip is None else floor_command(self.floor.take("floor", stamp_ns))

    def act(self, msg, stamp_ns: int) -> None:
        """Run the sample stamped ``stamp_ns`` whose input is ``msg`` (the subclass's)."""
        raise NotImplementedError

    def inputs_ready(self, stamp_ns: int) -> bool:
        """The subclass's other inputs for the sample stamped ``stamp_ns`` are in."""
        return True

    def offer(self, msg, stamp_ns: int) -> None:
        """An admitted sample: run it now or once its inputs are in."""
        self.pending.append((msg, stamp_ns))
        self.try_pending()

    def try_pending(self) -> None:
        """Run the waiting samples, oldest first, while their inputs are in."""
        while self.pending and self._run_first():
            pass

    def _run_first(self) -> bool:
        msg, stamp = self.pending[0]
        answer = self._protection_answer()
        if self.ctx.fast and self.sent_bhp_ref_pa and answer is None:
            return False
        if not self.inputs_ready(stamp) or \
                (self.trip is not None and not self.floor.has("floor", stamp)):
            return False
        self.pending.popleft()
        if answer is not None:
            window = (answer.bhp_window_low_pa, answer.bhp_window_high_pa)
            sent = self.sent_bhp_ref_pa.get(to_ns(answer.header.stamp), answer.bhp_ref_pa)
            self.publish_events(self.book.follow_protection(window, answer.bhp_ref_pa, sent),
                                stamp, "protection")
            self.speed_limits_mps = (answer.trip_speed_limit_in_mps,
                                     answer.trip_speed_limit_out_mps)
            self.applied_block_m = answer.block_position_ref_m
        self.act(msg, stamp)
        return True

    def _protection_answer(self) -> RigCommand | None:
        """The protection's answer to our last command (fast), its latest (realtime)."""
        if not self.machine:
            return None
        if not self.ctx.fast:
            return self.machine[max(self.machine)]
        return self.machine.get(max(self.sent_bhp_ref_pa, default=None))

    def _on_machine_command(self, msg: RigCommand) -> None:
        stamp = to_ns(msg.header.stamp)
        self.machine[stamp] = msg
        for old in [k for k in self.machine if k < stamp]:
            del self.machine[old]
        self.try_pending()

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
            self.event_pub.publish(event_message(e.notice, from_ns(stamp_ns), e.accepted))
        if self.book.changed:
            self.sp_pub.publish(to_msg(self.book.active, stamp_ns, source))
            self.book.changed = False

    def publish_command(self, command: AdvisorCommand, stamp_ns: int) -> None:
        """``command`` stamped ``stamp_ns`` with the book's BHP reference (NaN until resolved),
        the window it keeps to and its trip-speed limit (the protection takes the operator's
        limit from the command it limits, the same in every run)."""
        cmd = RigCommand(**asdict(SupervisorRequest.of(command, self.book)),
                         source=self.get_name())
        cmd.header.stamp = from_ns(stamp_ns)
        self.cmd_pub.publish(cmd)
        self.sent_bhp_ref_pa[stamp_ns] = cmd.bhp_ref_pa
        for old in sorted(self.sent_bhp_ref_pa)[:-SENT_KEPT]:
            del self.sent_bhp_ref_pa[old]
