"""Terminal alternative to the web console: the same validated setpoint requests, the
same latched level / emergency-stop topics and the same recorded operator events.

    python -m drill_hmi.operator_cli [--domain N] [--timeout S] COMMAND

    watch [--count N] [--period S]       one line per period (default 1 s): BHP, its window,
                                         choke dp, position, velocity, level, NMPC solve time
                                         (starts once the measurement, the estimate, the
                                         setpoints and the NMPC status are in, or --timeout
                                         has passed: a missing channel reads "-")
    setpoints [--bhp-bar X] [--bhp-band-bar B] [--dp-bar Y] [--dp-band-bar D]
              [--target-m Z] [--speed-mps V]
                                         change the named setpoints (the rest stay in force)
                                         through /set_setpoints; prints "accepted" or
                                         "refused: <reason>"
    controller on|off                    controller_enabled through /set_setpoints
    level manual|advisory|closed_loop    latched /operator/automation_level
    estop on|off                         latched /operator/emergency_stop

Before it acts, the CLI waits until DDS discovery has settled (every reader of the
topic matched, the picture stable for 1.5 s), so its events reach the recorder; one
action takes about 2-5 s. Exit codes (scriptable): 0 accepted / delivered, 1 refused or
not delivered (no service, no setpoints in force, no subscriber), 2 usage error.
``--domain`` sets ROS_DOMAIN_ID: the rig runs on an isolated domain, pass the one it
uses. Units: bar, m, m/s on the command line; SI on the wire.

Note: a latched level / emergency stop published here lives as long as this process;
the protection node keeps the state it received after we exit, but a node started
later sees only the console's latched value (if any).
"""
from __future__ import annotations

import argparse
import os
import sys
import threading
import time

from drill_hmi import console_state as cs
from drill_ros import graph as graph_decl

LEVEL_WORDS = cs.AUTOMATION_LEVELS
SETTLE_S = 1.5          # discovery picture stable this long before we publish


def parse_args(argv):
    parser = argparse.ArgumentParser(prog="operator_cli", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--domain", type=int, help="ROS_DOMAIN_ID of the rig (default: environment)")
    parser.add_argument("--timeout", type=float, default=10.0,
                        help="seconds to wait for the graph (setpoints, service, subscribers, "
                             "watch's channels)")
    parser.add_argument("--config-dir", default=None, help="config directory (pressure window)")
    sub = parser.add_subparsers(dest="command", required=True)
    watch = sub.add_parser("watch", help="print a live line per period")
    watch.add_argument("--count", type=int, default=0, help="stop after N lines (0: until Ctrl-C)")
    watch.add_argument("--period", type=float, default=1.0)
    sp = sub.add_parser("setpoints", help="request new setpoints")
    sp.add_argument("--bhp-bar", dest="bhp_bar")
    sp.add_argument("--bhp-band-bar", dest="bhp_band_bar")
    sp.add_argument("--dp-bar", dest="dp_bar")
    sp.add_argument("--dp-band-bar", dest="dp_band_bar")
    sp.add_argument("--target-m", dest="target_m")
    sp.add_argument("--speed-mps", dest="speed_mps")
    ctl = sub.add_parser("controller", help="controller on or off")
    ctl.add_argument("state", choices=("on", "off"))
    lvl = sub.add_parser("level", help="automation level")
    lvl.add_argument("level", choices=LEVEL_WORDS)
    stop = sub.add_parser("estop", help="emergency stop on (engage) or off (release)")
    stop.add_argument("state", choices=("on", "off"))
    return parser.parse_args(argv)


class Session:
    """An rclpy node spinning in a background thread, with the console's operator link
    and a ConsoleState fed by the display subscriptions."""

    def __init__(self, args, watch: bool):
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from drill_msgs.msg import NmpcStatus, RigMeasurement, Setpoints, StateEstimate
        from rclpy.executors import SingleThreadedExecutor
        from std_msgs.msg import Bool, String

        from drill_hmi import console
        from drill_ros import topics

        self.rclpy, self.topics, self.console = rclpy, topics, console
        rclpy.init(args=[])
        self.node = rclpy.create_node(f"operator_cli_{os.getpid()}")
        self.state = cs.ConsoleState(self._window(args.config_dir))
        self.link = console.OperatorLink(self.node, service_timeout_s=args.timeout, source="operator_cli")
        sub, st = self.node.create_subscription, self.state
        sub(Setpoints, topics.SETPOINTS, lambda m: st.on_setpoints(console.setpoints_to_dict(m)), topics.LATCHED)
        if watch:
            sub(String, topics.AUTOMATION_LEVEL, lambda m: st.on_level(m.data), topics.LATCHED)
            sub(Bool, topics.EMERGENCY_STOP, lambda m: st.on_estop(m.data), topics.LATCHED)
            sub(String, topics.LEVEL_IN_FORCE, lambda m: st.on_level_in_force(m.data), topics.LATCHED)
            sub(Bool, topics.ESTOP_IN_FORCE, lambda m: st.on_estop_in_force(m.data), topics.LATCHED)
            sub(RigMeasurement, topics.MEASUREMENT,
                lambda m: st.on_measurement(console.seconds(m.header.stamp), console.measurement_dict(m)),
                console.DISPLAY)
            sub(StateEstimate, topics.ESTIMATE,
                lambda m: st.on_estimate(console.seconds(m.header.stamp), console.estimate_dict(m)),
                console.DISPLAY)
            sub(NmpcStatus, topics.NMPC_STATUS,
                lambda m: st.on_nmpc(console.seconds(m.header.stamp), console.nmpc_dict(m)), console.DISPLAY)
            sub(DiagnosticArray, topics.DIAGNOSTICS, lambda m: console.take_diagnostics(st, m),
                console.DISPLAY)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    @staticmethod
    def _window(config_dir):
        from drill_core.config import load_rig
        from drill_core.rig_root import config_dir as default_config_dir
        try:
            return cs.Window.from_config(load_rig(config_dir or default_config_dir()))
        except Exception:                      # watch still works without the window
            return cs.Window(float("nan"), float("nan"))

    def _spin(self):
        while not self._stop.is_set():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception:                  # context shut down under us
                return

    def wait_for(self, predicate, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if predicate():
                return True
            time.sleep(0.05)
        return predicate()

    def _declared_readers_known(self, topic: str) -> bool:
        """Every running node that the graph declares a reader of ``topic`` (the recorder:
        every topic) has its subscription discovered, so the count above includes it: a
        node's endpoints are discovered one by one, and the recorder's found after we
        publish would miss the action."""
        for name, namespace in self.node.get_node_names_and_namespaces():
            declared = graph_decl.BY_NAME.get(name)
            if declared is None or not ({topic, graph_decl.EVERY_TOPIC} & set(declared.subscribes)):
                continue
            try:
                found = self.node.get_subscriber_names_and_types_by_node(name, namespace)
            except Exception:                  # the node vanished meanwhile
                return False
            if topic not in {t for t, _ in found}:
                return False
        return True

    def _endpoints_known(self) -> bool:
        """Every other node's endpoints have been discovered (each rclpy node publishes at
        least /rosout and /parameter_events), so subscriber counts are complete."""
        me = self.node.get_name()
        for name, namespace in self.node.get_node_names_and_namespaces():
            if name == me:
                continue
            try:
                if not self.node.get_publisher_names_and_types_by_node(name, namespace):
                    return False
            except Exception:                  # the node vanished meanwhile
                return False
        return True

    def readers_matched(self, publisher, topic: str, timeout: float, settle_s: float = SETTLE_S) -> bool:
        """Wait until the graph's endpoints are known, every subscriber of ``topic`` (at least
        one) is matched by ``publisher``, and that picture has been stable for ``settle_s``:
        discovery of a fresh process trickles in, and a volatile reader drops what it gets
        before it has matched us in turn."""
        deadline = time.monotonic() + timeout
        stable_since, last = None, None
        while time.monotonic() < deadline:
            picture = (len(self.node.get_node_names_and_namespaces()), self.node.count_subscribers(topic),
                       publisher.get_subscription_count())
            if picture[1] >= 1 and picture[2] >= picture[1] and self._endpoints_known() \
                    and self._declared_readers_known(topic):
                if picture != last:
                    stable_since, last = time.monotonic(), picture
                elif time.monotonic() - stable_since >= settle_s:
                    return True
            else:
                stable_since, last = None, None
            time.sleep(0.05)
        return False

    def flush(self, timeout: float = 3.0) -> bool:
        from rclpy.duration import Duration
        ok = True
        for pub in (self.link.pub_events, self.link.pub_level, self.link.pub_estop):
            ok &= bool(pub.wait_for_all_acked(Duration(seconds=timeout)))
        return ok

    def close(self):
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        self.rclpy.try_shutdown()


def _say(text: str, stream=sys.stdout) -> None:
    print(text, file=stream, flush=True)


def _watch_line(state: cs.ConsoleState) -> str:
    snap = state.snapshot(sys.maxsize)                    # latest values, no trend points
    m, e, sp, nm = snap["measurement"], snap["estimate"], snap["setpoints"], snap["nmpc"]
    w, auto = snap["window"], snap["automation"]

    def bar(v, d=1):
        return "-" if v is None else f"{v / cs.PA_PER_BAR:.{d}f}"

    def num(v, fmt):
        return "-" if v is None else format(v, fmt)
    ref = (sp or {}).get("bhp_ref_pa")
    if ref is None and nm:
        ref = nm.get("bhp_ref_pa")
    band = (sp or {}).get("bhp_band_pa")
    parts = [
        f"t={num((m or {}).get('t'), '.1f')}",
        f"BHP {bar((m or {}).get('bhp_pa'))} bar",
        f"[ref {bar(ref)}±{bar(band)} window {bar(w['pore_pressure_pa'], 0)}-"
        f"{bar(w['fracture_pressure_pa'], 0)}]",
        f"dp {bar((m or {}).get('choke_dp_pa'))} bar",
        f"pos {num((m or {}).get('block_position_m'), '.2f')} m",
        f"v {num((e or {}).get('string_velocity_mps'), '+.3f')} m/s",
        f"level {auto['level']}" + (" E-STOP" if auto["emergency_stop"] else ""),
        f"nmpc {num(nm['solve_time_s'] * 1e3 if nm and nm.get('solve_time_s') is not None else None, '.0f')} ms",
    ]
    return " ".join(parts)


def main(argv=None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if args.domain is not None:
        os.environ["ROS_DOMAIN_ID"] = str(args.domain)
    session = Session(args, watch=args.command == "watch")
    try:
        return _run(session, args)
    except KeyboardInterrupt:
        return 0
    finally:
        session.close()


def _run(session: Session, args) -> int:
    topics, link = session.topics, session.link
    if args.command == "watch":
        # complete lines from the start: wait (up to --timeout) for every channel; DDS
        # discovery of a fresh process on a busy machine can take seconds per publisher
        state = session.state
        if not session.wait_for(lambda: state.latest("measurement") is not None, args.timeout):
            _say(f"no {topics.MEASUREMENT} within {args.timeout:g} s on ROS_DOMAIN_ID "
                 f"{os.environ.get('ROS_DOMAIN_ID', '0')} (is the rig running?)", sys.stderr)
        others = {"estimate": topics.ESTIMATE, "setpoints": topics.SETPOINTS, "nmpc": topics.NMPC_STATUS}
        session.wait_for(lambda: all(state.latest(k) is not None for k in others), args.timeout)
        missing = [topic for k, topic in others.items() if state.latest(k) is None]
        if missing:
            _say(f"nothing yet on {', '.join(missing)}", sys.stderr)
        n = 0
        while args.count <= 0 or n < args.count:
            time.sleep(args.period)
            _say(_watch_line(session.state))
            n += 1
        return 0

    # the recorder (and any console) must be matched on /operator/events before we act
    if not session.readers_matched(link.pub_events, topics.OPERATOR_EVENTS, args.timeout):
        _say(f"warning: no reader of {topics.OPERATOR_EVENTS} matched within {args.timeout:g} s: "
             "this action may not be recorded", sys.stderr)
    if args.command in ("level", "estop"):
        if args.command == "level":
            pub, topic = link.pub_level, topics.AUTOMATION_LEVEL
        else:
            pub, topic = link.pub_estop, topics.EMERGENCY_STOP
        if not session.readers_matched(pub, topic, args.timeout):
            _say(f"not delivered: no subscriber on {topic} within {args.timeout:g} s "
                 f"(is the protection node running on ROS_DOMAIN_ID "
                 f"{os.environ.get('ROS_DOMAIN_ID', '0')}?)", sys.stderr)
            return 1
        if args.command == "level":
            link.set_level(args.level, " (hand back to manual)" if args.level == "manual" else "")
            what = f"automation level {args.level}"
        else:
            link.set_estop(args.state == "on")
            what = "emergency stop " + ("engaged" if args.state == "on" else "released")
        if not session.flush(args.timeout):
            _say(f"not acknowledged by every subscriber of {topic}: {what}", sys.stderr)
            return 1
        _say(f"delivered: {what}")
        return 0

    # setpoints and controller: through the validating service
    if not session.wait_for(lambda: session.state.active_setpoints() is not None, args.timeout):
        _say(f"refused: no setpoints in force on {topics.SETPOINTS} within {args.timeout:g} s "
             f"(is the supervisor running?)", sys.stderr)
        return 1
    active = session.state.active_setpoints()
    try:
        if args.command == "controller":
            request = cs.build_request(active, {"controller_enabled": args.state == "on"})
            what = f"controller {args.state}"
        else:
            form = {k: getattr(args, k) for k in cs.FORM_FIELDS if getattr(args, k) is not None}
            request = cs.build_request(active, form)
            what = cs.describe_changes(active, request)
    except cs.FormError as err:
        link.refuse(args.command, str(err))
        session.flush(args.timeout)
        _say(f"refused: {err}")
        return 1
    result = link.request_setpoints(request, what)
    session.flush(args.timeout)
    if result["accepted"]:
        _say(f"accepted: {what}")
        return 0
    _say(f"refused: {result['reason']}")
    return 1


if __name__ == "__main__":
    sys.exit(main())
