"""Operator console: a local web page fed by DDS (docs/design.md §2 and §10).

Run (inside ``source scripts/env.sh``, on the rig's ROS_DOMAIN_ID)::

    python -m drill_hmi.console --ros-args -p port:=8080 \\
        -p config_dir:=config -p scenario:=config/scenarios/short_trip.yaml

then open http://127.0.0.1:8080/ on this machine. Parameters: ``port`` (8080; 0 picks a
free port; a port in use falls back to a free one unless ``port_fallback`` is false —
the URL is printed as ``CONSOLE_URL http://...``), ``host`` (127.0.0.1: loopback only),
``security_dir`` (a directory of ``rig certs``: every action then needs its
``console-token``; a ``host`` other machines reach refuses to start without one,
docs/security.md), ``config_dir`` and ``scenario`` (pressure window from
protection.yaml with the scenario's overrides), ``mode``, ``stand_length_m`` (28 m,
the pull-out / run-in step), ``service_timeout_s`` (5 s).

The page is one self-contained HTML file (``console_page.html`` next to this module:
inline JS and canvas trends, no external assets). It polls the JSON API below twice a
second. The rclpy side (this module) only converts messages to plain dicts and turns
operator actions into service calls and messages; the state, trend buffers, unit
conversion and form validation live in :mod:`drill_hmi.console_state`.

Sources: /rig/measurement, /estimator/estimate, /nmpc/status, /setpoints (latched),
/actuators/<name>/frame, /<node>/status, /operator/events, /protection/events,
/operator/automation_level and /operator/emergency_stop (latched), and /rig/truth,
shown labelled "truth (simulation)" for evaluation only; on a multi-stand trip /rig/floor,
whose steps with the measurements keep the live trip sheet (``trip_sheet`` in the state).
Display subscriptions are best-effort keep-last, so a slow console can never hold up the
graph (a frame it misses is passed over by its trip sheet; the report's, from the
recording, is the record).

JSON API (SI units in every response; the request bodies use the page's display
units where the key says so — ``_bar`` keys are bar, converted to Pa here)::

    GET  /                 the page
    GET  /api/state?since=N
         everything the page shows: latest measurement / estimate / truth / NMPC
         status / setpoints / actuator frames / node statuses, the pressure window,
         the automation level in force ("automation": level, source, requested,
         emergency_stop), recent events, the last action's result, the trip sheet
         (None but on a multi-stand trip: its rows, SI, as the report's), and the trend
         points with sequence number > N ("trends": {series: [[t_s, value_SI], ...]},
         "seq": newest sequence number — pass it back as ``since``).
    POST /api/setpoints    {"bhp_bar", "bhp_band_bar", "dp_bar", "dp_band_bar",
                            "target_m", "speed_mps", "controller_enabled", "mud_pump_on"}
         any subset; absent or empty fields keep the setpoints in force. Sent through
         the /set_setpoints service; answers {"accepted", "reason", "active", ...}.
    POST /api/trip         {"direction": "out" | "in"}: trip target one stand above /
                           below the target in force (through the service).
    POST /api/controller   {"enabled": true | false} (controller_enabled via the service)
    POST /api/level        {"level": "manual" | "advisory" | "closed_loop"}
                           (latched /operator/automation_level)
    POST /api/estop        {"engaged": true | false} (latched /operator/emergency_stop)
    POST /api/ack          {"id": N} or {"all": true}: acknowledge protection alarms,
                           clamps and refusals.

Every POST answers {"accepted": bool, "reason": str, ...} with HTTP 200 (a refusal is
an answer, not an error); malformed requests get 400, and with a token a POST without
``Authorization: Bearer TOKEN`` gets 401 (the page asks for the token once per tab).
Reads need no token. POST bodies must be ``application/json`` (so a cross-site form
cannot post), and the Host header must name this machine (or the bound address). Every operator action and acknowledgement, accepted or not, is
published as drill_msgs/OperatorEvent on /operator/events, so the recorder keeps it.
"""
from __future__ import annotations

import errno
import json
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from urllib.parse import parse_qs, urlparse

from diagnostic_msgs.msg import DiagnosticArray
from drill_msgs.msg import (ActuatorFrame, NmpcStatus, OperatorEvent, PlantTruth, RigFloor,
                            RigMeasurement, Setpoints, StateEstimate)
from drill_msgs.srv import SetSetpoints
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool, String

from drill_hmi import console_state as cs
from drill_core import access
from drill_core.access import SecurityDir
from drill_core.config import load_rig
from drill_core.event_codes import Notice
from drill_core.rig_root import config_dir as default_config_dir
from drill_core.state_layout import annulus_pressure_name
from drill_ros import topics
from drill_ros.diagnostics import HARDWARE_ID, status_fields
from drill_ros.events import event_message
from drill_ros.node import RigNode
from drill_ros.runner import run
from drill_ros.floor import floor_command, floor_programme
from drill_ros.stamps import seconds_to_ns, to_ns
from drill_ros.status import StatusReporter
from drill_core.scenario import load_scenario_config
from drill_core.tripping.sheet_feed import TripSheetFeed
from drill_core.tripping.stands import StandVolumes
from drill_core.well import build_geometry

DISPLAY = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5,
                     reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)
MAX_BODY_BYTES = 16384
WILDCARD_HOSTS = ("0.0.0.0", "::")       # bound to every interface: any Host header is ours
TOKEN_NEEDED = "this console takes an action only with its token (Authorization: Bearer TOKEN)"


def page_html() -> str:
    """The console page (console_page.html shipped next to this module)."""
    try:
        return resources.files("drill_hmi").joinpath("console_page.html").read_text("utf-8")
    except (FileNotFoundError, ModuleNotFoundError, TypeError):
        return (Path(__file__).with_name("console_page.html")).read_text("utf-8")


def seconds(stamp) -> float:
    return to_ns(stamp) * 1e-9


def setpoints_to_dict(msg: Setpoints) -> dict:
    out = {name: getattr(msg, name) for name in cs.SETPOINT_FIELDS}
    out["source"] = msg.source
    out["t"] = seconds(msg.header.stamp)
    return out


def setpoints_from_dict(values: dict) -> Setpoints:
    msg = Setpoints()
    for name in cs.SETPOINT_FIELDS:
        value = values[name]
        setattr(msg, name, bool(value) if name in cs.BOOL_FIELDS else float(value))
    msg.source = str(values.get("source", "operator"))
    return msg


def measurement_dict(m: RigMeasurement) -> dict:
    return {"block_position_m": m.block_position_m, "choke_dp_pa": m.choke_dp_pa, "bhp_pa": m.bhp_pa,
            "string_flow_m3s": m.string_flow_m3s, "string_flow_valid": m.string_flow_valid,
            "return_flow_m3s": m.return_flow_m3s, "pit_volume_m3": m.pit_volume_m3,
            "bpp_flow_m3s": m.bpp_flow_m3s, "hook_load_n": m.hook_load_n,
            "trip_tank_volume_m3": m.trip_tank_volume_m3}


def truth_dict(m: PlantTruth) -> dict:
    return {"bhp_pa": m.bhp_pa, "string_velocity_mps": m.string_velocity_mps,
            "string_position_m": m.string_position_m, "block_position_m": m.block_position_m,
            "ecd_kgm3": m.ecd_kgm3, "choke_opening": m.choke_opening, "spp_pa": m.spp_pa,
            "bpp_flow_m3s": m.bpp_flow_m3s, "string_flow_m3s": m.string_flow_m3s}


def estimate_dict(m: StateEstimate) -> dict:
    value = {name: float(v) for name, v in zip(m.state_names, m.mean)}
    pressures = []                           # p_1..p_n, while the estimate names them
    while annulus_pressure_name(len(pressures) + 1) in value:
        pressures.append(value[annulus_pressure_name(len(pressures) + 1)])
    return {"annulus_pressures_pa": pressures, "bhp_pa": m.bhp_pa, "choke_dp_pa": m.choke_dp_pa,
            "string_velocity_mps": m.string_velocity_mps,
            "string_position_m": value.get("string_position_m"),
            "nis": m.nis, "nis_dof": int(m.nis_dof), "string_flow_observable": m.string_flow_observable,
            "rejected_measurements": int(m.rejected_measurements),
            "covariance_inflations": int(m.covariance_inflations),
            "bottom_influx_m3s": m.bottom_influx_m3s}


def nmpc_dict(m: NmpcStatus) -> dict:
    return {"configuration": m.configuration, "solve_time_s": m.solve_time_s, "iterations": int(m.iterations),
            "solver_status": m.solver_status, "success": m.success, "fallback": m.fallback,
            "fallback_count": int(m.fallback_count), "cost": m.cost, "bhp_ref_pa": m.bhp_ref_pa,
            "block_position_ref_m": m.block_position_ref_m,
            "slacks": dict(zip(m.slack_names, (float(v) for v in m.slack_max)))}


def frame_dict(m: ActuatorFrame) -> dict:
    return {"unit": m.unit, "command": m.command, "output": [float(m.output[-1])] if len(m.output) else [],
            "reference": m.reference, "watchdog_active": m.watchdog_active}


def take_diagnostics(state, m: DiagnosticArray, own_name: str = "") -> None:
    """Hand each rig node's report of a /diagnostics message (but ``own_name``'s) to a
    console state."""
    for report in m.status:
        if report.hardware_id == HARDWARE_ID and report.name != own_name:
            state.on_status(report.name, status_fields(report))


def console_token(host: str, security_dir: str) -> str | None:
    """The token every action must carry (the security directory's console-token), None
    for a console on this machine only without one; ConfigError for a console other
    machines reach without one."""
    access.require_security_beyond_loopback(host, security_dir or None, "the console")
    return SecurityDir(Path(security_dir)).console_token() if security_dir else None


class OperatorLink:
    """The console's and the terminal CLI's shared way of acting on the rig: the
    validating setpoint service, the latched level / emergency-stop topics and the
    event log. Thread-safe (one action at a time)."""

    def __init__(self, node: RigNode, service_timeout_s: float = 5.0, source: str = "console"):
        self.node = node
        self.source = source
        self.service_timeout_s = service_timeout_s
        self._lock = threading.Lock()
        self.client = node.create_client(SetSetpoints, topics.SET_SETPOINTS)
        self.pub_events = node.create_publisher(OperatorEvent, topics.OPERATOR_EVENTS, topics.EVENT_LOG)
        self.pub_level = node.create_publisher(String, topics.AUTOMATION_LEVEL, topics.LATCHED)
        self.pub_estop = node.create_publisher(Bool, topics.EMERGENCY_STOP, topics.LATCHED)

    def event(self, notice: Notice, accepted: bool = True) -> None:
        self.pub_events.publish(event_message(notice, self.node.get_clock().now().to_msg(),
                                              accepted, f"[{self.source}] "))

    def request_setpoints(self, request: dict, what: str) -> dict:
        """Call /set_setpoints with the SI ``request``; publish the outcome as an event."""
        with self._lock:
            accepted, reason, active = False, "", None
            if not self.client.wait_for_service(timeout_sec=min(2.0, self.service_timeout_s)):
                reason = f"setpoint service {topics.SET_SETPOINTS} is not available (is the supervisor running?)"
            else:
                req = SetSetpoints.Request()
                req.setpoints = setpoints_from_dict(request)
                req.setpoints.header.stamp = self.node.get_clock().now().to_msg()
                response = self.client.call(req, timeout_sec=self.service_timeout_s)
                if response is None:
                    reason = (f"no answer from {topics.SET_SETPOINTS} within "
                              f"{self.service_timeout_s:g} s")
                else:
                    accepted, reason = bool(response.accepted), response.reason
                    active = setpoints_to_dict(response.active)
                    if active["source"] in ("", "active"):     # the supervisor's label for "in force"
                        active["source"] = request.get("source", "operator") if accepted else ""
                    if not active["source"]:
                        active = None                            # keep the latched copy as it is
                    if not accepted and not reason:
                        reason = "refused (the supervisor gave no reason)"
            if accepted:
                self.event(Notice("operator_setpoints_accepted", f"setpoints accepted: {what}"))
            else:
                self.event(Notice("operator_setpoints_refused",
                                  f"setpoints refused ({what}): {reason}"), False)
            return {"accepted": accepted, "reason": "" if accepted else reason, "active": active,
                    "requested": request, "detail": what}

    def set_level(self, level: str, note: str = "") -> dict:
        with self._lock:
            self.pub_level.publish(String(data=level))
            self.event(Notice("level_requested", f"automation level {level} requested{note}"))
            return {"accepted": True, "reason": "", "level": level}

    def set_estop(self, engaged: bool) -> dict:
        with self._lock:
            self.pub_estop.publish(Bool(data=bool(engaged)))
            self.event(Notice("estop_requested" if engaged else "estop_release_requested",
                              "emergency stop " + ("ENGAGED" if engaged else "released")))
            return {"accepted": True, "reason": "", "engaged": bool(engaged)}

    def acknowledge(self, text: str) -> None:
        with self._lock:
            self.event(Notice("acknowledged", text))

    def refuse(self, action: str, reason: str) -> dict:
        """An operator input the console could not turn into a request: logged too."""
        with self._lock:
            self.event(Notice("request_refused", f"{action} not done: {reason}"), False)
        return {"accepted": False, "reason": reason}


class ConsoleNode(RigNode):
    def __init__(self, **node_options):
        super().__init__("console", **node_options)
        config_dir = self.declare_parameter("config_dir", str(default_config_dir())).value
        scenario = self.declare_parameter("scenario", "").value
        self.mode = self.declare_parameter("mode", "realtime").value
        port = int(self.declare_parameter("port", 8080).value)
        host = self.declare_parameter("host", "127.0.0.1").value
        stand = float(self.declare_parameter("stand_length_m", cs.STAND_LENGTH_M).value)
        timeout = float(self.declare_parameter("service_timeout_s", 5.0).value)
        port_fallback = bool(self.declare_parameter("port_fallback", True).value)
        security_dir = self.declare_parameter("security_dir", "").value
        self.token = console_token(host, security_dir)
        config = load_scenario_config(scenario, config_dir)[1] if scenario else load_rig(config_dir)
        self.state = cs.ConsoleState(cs.Window.from_config(config), stand_length_m=stand)
        self.geometry = build_geometry(config.well)             # the trip sheet's stand volumes
        self.frame_ns = seconds_to_ns(config.plant.sensor_period_s)
        self.link = OperatorLink(self, timeout, source="console")
        self.exit_code = 0
        self.counters = {"http_requests": 0.0, "actions": 0.0, "refusals": 0.0}

        sub = self.create_subscription
        sub(RigMeasurement, topics.MEASUREMENT, self._on_measurement, DISPLAY)
        sub(RigFloor, topics.FLOOR, self._on_floor, DISPLAY)
        sub(PlantTruth, topics.TRUTH, self._on_truth, DISPLAY)
        sub(StateEstimate, topics.ESTIMATE, self._on_estimate, DISPLAY)
        sub(NmpcStatus, topics.NMPC_STATUS, self._on_nmpc, DISPLAY)
        sub(Setpoints, topics.SETPOINTS, lambda m: self.state.on_setpoints(setpoints_to_dict(m)),
            topics.LATCHED)
        sub(OperatorEvent, topics.OPERATOR_EVENTS, lambda m: self._on_event("operator", m), topics.EVENT_LOG)
        sub(OperatorEvent, topics.PROTECTION_EVENTS, lambda m: self._on_event("protection", m),
            topics.EVENT_LOG)
        sub(OperatorEvent, topics.RIG_EVENTS, lambda m: self._on_event("rig", m), topics.EVENT_LOG)
        sub(String, topics.AUTOMATION_LEVEL, lambda m: self.state.on_level(m.data), topics.LATCHED)
        sub(Bool, topics.EMERGENCY_STOP, lambda m: self.state.on_estop(m.data), topics.LATCHED)
        sub(String, topics.LEVEL_IN_FORCE, lambda m: self.state.on_level_in_force(m.data),
            topics.LATCHED)
        sub(Bool, topics.ESTOP_IN_FORCE, lambda m: self.state.on_estop_in_force(m.data),
            topics.LATCHED)
        for name in topics.ACTUATORS:
            sub(ActuatorFrame, topics.actuator_frame(name), lambda m, n=name: self._on_frame(n, m), DISPLAY)
        sub(DiagnosticArray, topics.DIAGNOSTICS,
            lambda m: take_diagnostics(self.state, m, self.get_name()), DISPLAY)

        self.status = StatusReporter(self, self.mode)
        try:
            self.server = ConsoleServer((host, port), self)
        except OSError as err:
            if err.errno != errno.EADDRINUSE or not port_fallback:
                raise
            self.get_logger().warning(f"port {port} is in use: serving on a free port instead")
            self.server = ConsoleServer((host, 0), self)
        self.port = self.server.server_address[1]
        self._thread = threading.Thread(target=self.server.serve_forever, name="console-http", daemon=True)
        self._thread.start()
        self.create_timer(1.0, self._tick)
        self.get_logger().info(f"console on http://{host}:{self.port}/")
        print(f"CONSOLE_URL http://{host}:{self.port}/", flush=True)

    # ------------------------------------------------------------------ inputs
    def _on_measurement(self, m: RigMeasurement) -> None:
        self.state.on_measurement(seconds(m.header.stamp), measurement_dict(m),
                                  to_ns(m.header.stamp))

    def _on_floor(self, m: RigFloor) -> None:
        def start_sheet() -> TripSheetFeed:
            programme = floor_programme(m)
            return TripSheetFeed(programme, StandVolumes.of(self.geometry, programme.stand_length_m),
                                 self.frame_ns)
        self.state.on_floor(to_ns(m.header.stamp), floor_command(m).step, start_sheet)

    def _on_truth(self, m: PlantTruth) -> None:
        self.state.on_truth(seconds(m.header.stamp), truth_dict(m))

    def _on_estimate(self, m: StateEstimate) -> None:
        self.state.on_estimate(seconds(m.header.stamp), estimate_dict(m))

    def _on_nmpc(self, m: NmpcStatus) -> None:
        self.state.on_nmpc(seconds(m.header.stamp), nmpc_dict(m))

    def _on_frame(self, name: str, m: ActuatorFrame) -> None:
        self.state.on_frame(name, seconds(m.header.stamp), frame_dict(m))


    def _on_event(self, source: str, m: OperatorEvent) -> None:
        self.state.on_event(source, seconds(m.header.stamp), m.kind, m.code, m.text, m.accepted)

    def _tick(self) -> None:
        self.status.values = dict(self.counters, port=float(self.port))
        self.status.tick(self.get_clock().now().nanoseconds)

    # ------------------------------------------------------------------ actions (HTTP threads)
    def act(self, path: str, body: dict) -> dict:
        """Run one POST action; every outcome is also kept as the page's last result."""
        self.counters["actions"] += 1
        action = path.rsplit("/", 1)[-1]
        try:
            result = self._dispatch(action, body)
        except cs.FormError as err:
            result = self.link.refuse(action, str(err))
        if not result["accepted"]:
            self.counters["refusals"] += 1
        self.state.set_result(action, result["accepted"], result.get("reason", ""),
                              result.get("detail", ""))
        if result.get("active") is not None:
            self.state.on_setpoints(result["active"])
        return result

    def refuse_unauthorised(self, path: str) -> None:
        """An action without the console's token: counted and recorded, nothing done."""
        self.counters["actions"] += 1
        self.counters["refusals"] += 1
        self.link.refuse(path.rsplit("/", 1)[-1], "no valid console token")

    def _dispatch(self, action: str, body: dict) -> dict:
        state = self.state
        if action == "setpoints":
            active = state.active_setpoints()
            request = cs.build_request(active, body)
            return self.link.request_setpoints(request, cs.describe_changes(active, request))
        if action == "trip":
            active = state.active_setpoints()
            direction = str(body.get("direction", ""))
            target = cs.stand_target(active, direction, state.stand_length_m)
            request = cs.build_request(active, {"target_m": target})
            word = "pull out" if direction == "out" else "run in"
            return self.link.request_setpoints(
                request, f"{word} a stand: {cs.describe_changes(active, request)}")
        if action == "controller":
            enabled = cs.parse_bool(body.get("enabled"), "enabled")
            if enabled is None:
                raise cs.FormError("enabled: expected true or false")
            active = state.active_setpoints()
            request = cs.build_request(active, {"controller_enabled": enabled})
            return self.link.request_setpoints(request, "controller " + ("on" if enabled else "off"))
        if action == "level":
            level = cs.level_or_error(str(body.get("level", "")))
            note = " (hand back to manual)" if level == "manual" and body.get("hand_back") else ""
            return self.link.set_level(level, note)
        if action == "estop":
            engaged = cs.parse_bool(body.get("engaged"), "engaged")
            if engaged is None:
                raise cs.FormError("engaged: expected true or false")
            return self.link.set_estop(engaged)
        if action == "ack":
            if body.get("all"):
                done = state.acknowledge(None)
            else:
                try:
                    event_id = int(body.get("id"))
                except (TypeError, ValueError):
                    raise cs.FormError("ack: expected {\"id\": N} or {\"all\": true}") from None
                done = state.acknowledge(event_id)
            if done:
                ids = ", ".join(f"#{e['id']}" for e in done) if len(done) <= 8 \
                    else f"#{done[0]['id']} ... #{done[-1]['id']}"
                last = done[-1]["text"]
                self.link.acknowledge(f"acknowledged {len(done)} event(s) {ids}: {last}"
                                      if len(done) > 1 else f"acknowledged {ids}: {last}")
            return {"accepted": True, "reason": "", "acknowledged": [e["id"] for e in done]}
        raise cs.FormError(f"unknown action {action!r}")

    def destroy_node(self):
        self.server.shutdown()
        self.server.server_close()
        return super().destroy_node()


class ConsoleServer(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, address, node: ConsoleNode):
        self.node = node
        self.page = page_html().encode("utf-8")
        super().__init__(address, ConsoleHandler)


class ConsoleHandler(BaseHTTPRequestHandler):
    server: ConsoleServer
    server_version = "RigConsole/1"

    def log_message(self, fmt, *args):   # quiet: the node logs what matters
        pass

    def _send(self, code: int, body: bytes, content_type: str) -> None:
        self.send_response(code)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.end_headers()
        self.wfile.write(body)

    def _json(self, code: int, payload: dict) -> None:
        self._send(code, json.dumps(cs.clean(payload), allow_nan=False).encode("utf-8"),
                   "application/json; charset=utf-8")

    def _host_ok(self) -> bool:
        host = (self.headers.get("Host") or "").strip()
        name = host.rsplit(":", 1)[0] if not host.endswith("]") else host
        name = name.strip("[]")
        bound = self.server.server_address[0]
        return access.is_loopback(name) or name == bound or bound in WILDCARD_HOSTS

    def _authorised(self) -> bool:
        token = self.server.node.token
        if token is None:
            return True
        scheme, _, given = (self.headers.get("Authorization") or "").partition(" ")
        return scheme == "Bearer" and access.token_matches(given.strip(), token)

    def do_GET(self):
        self.server.node.counters["http_requests"] += 1
        if not self._host_ok():
            return self._json(403, {"accepted": False, "reason": "unexpected Host header"})
        url = urlparse(self.path)
        if url.path in ("/", "/index.html"):
            return self._send(200, self.server.page, "text/html; charset=utf-8")
        if url.path == "/api/state":
            try:
                since = int(parse_qs(url.query).get("since", ["0"])[0])
            except ValueError:
                since = 0
            return self._json(200, self.server.node.state.snapshot(since))
        return self._json(404, {"accepted": False, "reason": f"no such page {url.path}"})

    def do_POST(self):
        self.server.node.counters["http_requests"] += 1
        if not self._host_ok():
            return self._json(403, {"accepted": False, "reason": "unexpected Host header"})
        path = urlparse(self.path).path
        if path not in ("/api/setpoints", "/api/trip", "/api/controller", "/api/level", "/api/estop",
                        "/api/ack"):
            return self._json(404, {"accepted": False, "reason": f"no such action {path}"})
        if not self._authorised():
            self.server.node.refuse_unauthorised(path)
            return self._json(401, {"accepted": False, "reason": TOKEN_NEEDED})
        if not (self.headers.get("Content-Type") or "").startswith("application/json"):
            return self._json(415, {"accepted": False, "reason": "send application/json"})
        try:
            length = int(self.headers.get("Content-Length") or 0)
            if length > MAX_BODY_BYTES:
                raise ValueError("request too large")
            body = json.loads(self.rfile.read(length) or b"{}")
            if not isinstance(body, dict):
                raise ValueError("expected a JSON object")
        except ValueError as err:
            return self._json(400, {"accepted": False, "reason": f"bad request: {err}"})
        try:
            result = self.server.node.act(path, body)
        except Exception as err:   # keep serving; report the failure on the page
            self.server.node.get_logger().error(f"{path}: {type(err).__name__}: {err}")
            return self._json(500, {"accepted": False, "reason": f"{type(err).__name__}: {err}"})
        return self._json(200, result)


def main(args=None) -> None:
    sys.exit(run(ConsoleNode, args))


if __name__ == "__main__":
    main()
