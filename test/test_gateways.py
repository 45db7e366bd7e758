"""The gateways on a live run: the short trip in realtime with the Foxglove bridge, the
OPC-UA gateway and the WITS0 stream (``rig run short_trip --realtime --foxglove --opcua
--wits0``), on a ROS domain of its own.

* Foxglove: a client speaking the Foxglove WebSocket protocol gets the rig's channels
  with their ros2msg schemas, subscribes to /rig/measurement and decodes its CDR frames:
  a plausible BHP, stamps that advance.
* OPC-UA, the gateway bound to every interface with a security directory (``rig run
  ... --opcua opc.tcp://0.0.0.0:PORT/drill-rig --security DIR``): an asyncua client
  signed-and-encrypted as an operator browses to Rig/Measurements/DownholePressure by
  name (the namespace index from the rig's URI), reads it and sees it change through a
  subscription; a valid BHP setpoint reaches the latched /setpoints, one above the
  fracture pressure comes back Bad with the supervisor's reason and changes nothing;
  both are on /operator/events as the console's are; the automation level written goes
  through the process protection. An anonymous session reads, and its write comes back
  BadUserAccessDenied, changes nothing and is on /operator/events.
* WITS0: a TCP client of the gateway parses record 01 frames with a parser written from
  the public record layout (test/support/wits0_client.py): a plausible BHP and
  bit depth, times that advance.

At the end no process of the run, the gateways' included, stops with a failure (an exit
code > 0).
"""
from __future__ import annotations

import asyncio
import math
import re
import socket

import pytest
from asyncua import Client, ua
from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256
from drill_msgs.msg import OperatorEvent, RigMeasurement, Setpoints
from foxglove_client import FoxgloveClient
from rclpy.serialization import deserialize_message
from rig_testing import held_test_domain, spinning_node, wait_for
from wits0_client import parse_frames

from drill_bringup import launcher
from drill_rig import cli
from drill_core import access
from drill_ros import topics
from drill_gateway import certificates
from drill_gateway import opcua_names as names

pytestmark = [pytest.mark.dds, pytest.mark.slow, pytest.mark.realtime,
              pytest.mark.filterwarnings("ignore::DeprecationWarning")]

DOMAIN_ID = held_test_domain()
SCENARIO = cli.ROOT / "config" / "scenarios" / "short_trip.yaml"
TIMEOUT_S = 60.0
START_TIMEOUT_S = 240.0               # the whole graph up, on a machine that may be busy
PHYSICAL_BHP_PA = (5.0e7, 8.0e7)      # the reference well's BHP is ~685 bar
OPERATOR, PASSWORD = "olivia", "olivia-pass"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def reported(launch, name: str, key: str) -> str:
    log = launch.logs / f"{name}.log"
    match = re.search(rf"{key} (\S+)", log.read_text(errors="replace")) if log.exists() else None
    dead = [(n, p.poll()) for n, p in launch.procs.items() if p.poll() not in (None, 0)]
    if dead:
        pytest.fail(launch.failure(*dead[0]))
    return match.group(1) if match else ""


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("gateways")
    security = certificates.make(run_dir / "security", [socket.gethostname(), "localhost", "127.0.0.1"])
    certificates.add_user(security.path, OPERATOR, access.OPERATOR, PASSWORD)
    common = {"config_dir": str(cli.ROOT / "config"), "scenario": str(SCENARIO), "mode": "realtime"}
    port = free_port()
    nodes = launcher.graph("nmpc", common, run_dir / "trip.mcap", fast=False, extras={
        "foxglove_bridge": {"port": 0},
        "opcua_gateway": {"endpoint": f"opc.tcp://0.0.0.0:{port}/drill-rig",
                          "security_dir": str(security.path)},
        "wits0_gateway": {"address": "127.0.0.1:0"}})
    next(n for n in nodes if n.name == "console").params["port"] = 0
    launch = launcher.Launch(nodes, run_dir, DOMAIN_ID)
    seen = {"setpoints": [], "events": []}
    with pytest.MonkeyPatch.context() as monkeypatch, \
            spinning_node(DOMAIN_ID, "gateway_test_listener", monkeypatch) as node:
        node.create_subscription(Setpoints, topics.SETPOINTS, seen["setpoints"].append, topics.LATCHED)
        node.create_subscription(OperatorEvent, topics.OPERATOR_EVENTS, seen["events"].append,
                                 topics.RELIABLE)
        try:
            launch.start()
            wait_for(lambda: reported(launch, "foxglove_bridge", "FOXGLOVE_URL"), START_TIMEOUT_S,
                     "the bridge's URL")
            wait_for(lambda: reported(launch, "opcua_gateway", "OPCUA_URL"), START_TIMEOUT_S,
                     "the gateway's endpoint")
            # its events are volatile: written before this listener has matched the gateway's
            # writer (discovery on a busy machine takes seconds), they do not reach it
            wait_for(lambda: any(i.node_name == "opcua_gateway" for i in
                                 node.get_publishers_info_by_topic(topics.OPERATOR_EVENTS)),
                     START_TIMEOUT_S, f"the gateway's writer of {topics.OPERATOR_EVENTS}")
            wait_for(lambda: reported(launch, "wits0_gateway", "WITS0_ADDRESS"), START_TIMEOUT_S,
                     "the WITS0 stream's address")
            yield {"launch": launch, "seen": seen, "security": security,
                   "wits0": reported(launch, "wits0_gateway", "WITS0_ADDRESS"),
                   "endpoint": f"opc.tcp://127.0.0.1:{port}/drill-rig",
                   "foxglove": reported(launch, "foxglove_bridge", "FOXGLOVE_URL")}
        finally:
            codes = launch.stop()
            print(f"[gateway test] exit codes {codes}; logs in {launch.logs}", flush=True)
    # A node that fails exits with its own code (> 0). A negative one is a signal: the
    # launcher's SIGKILL when a process has not ended 10 s after its SIGINT (once in about
    # 100 runs here: an actuator, past its spin loop, its time budget written; not a
    # gateway).
    failed = {name: code for name, code in codes.items() if code > 0}
    assert not failed, "\n".join(launch.failure(n, c) for n, c in failed.items())


def test_a_foxglove_client_decodes_live_measurements(live):
    async def session():
        async with FoxgloveClient(live["foxglove"]) as client:
            await client.wait_for_channels([topics.MEASUREMENT, topics.SETPOINTS], TIMEOUT_S)
            await client.subscribe(topics.MEASUREMENT)
            frames = [await client.next_message(TIMEOUT_S) for _ in range(5)]
            return client.channels, frames

    channels, frames = asyncio.run(session())
    channel = channels[topics.MEASUREMENT]
    assert (channel["encoding"], channel["schemaEncoding"]) == ("cdr", "ros2msg")
    assert channel["schemaName"] == "drill_msgs/msg/RigMeasurement"
    assert "float64 bhp_pa" in channel["schema"] and "MSG: std_msgs/Header" in channel["schema"]
    decoded = [deserialize_message(payload, RigMeasurement) for _, _, payload in frames]
    for m in decoded:
        assert math.isfinite(m.bhp_pa) and PHYSICAL_BHP_PA[0] < m.bhp_pa < PHYSICAL_BHP_PA[1], m.bhp_pa
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in decoded]
    assert all(b > a for a, b in zip(stamps, stamps[1:])), stamps


def test_a_wits0_client_parses_live_record_01_frames(live):
    host, _, port = live["wits0"].rpartition(":")
    with socket.create_connection((host, int(port)), timeout=TIMEOUT_S) as client:
        data = b""
        while data.count(b"!!\r\n") < 4:
            chunk = client.recv(4096)
            assert chunk, "the gateway closed the stream"
            data += chunk
    frames = parse_frames(data)[-3:]               # the first may have been cut
    assert len(frames) == 3
    for items in frames:
        assert items["0101"] == "short_trip"
        assert PHYSICAL_BHP_PA[0] < float(items["0141"]) * 1e3 < PHYSICAL_BHP_PA[1], items
        assert 3500.0 < float(items["0108"]) < 3700.0, items       # bit depth [m]
    times = [items["0105"] + items["0106"] for items in frames]
    assert times == sorted(times) and len(set(times)) == 3, times


def test_an_opcua_client_browses_reads_subscribes_and_writes_through_the_supervisor(live):
    seen = live["seen"]

    class Changes:
        def __init__(self):
            self.values = []

        def datachange_notification(self, node, value, data):
            self.values.append(value)

    async def until(read, predicate, what):
        """Poll ``read`` (a coroutine function, or a plain one) until ``predicate`` holds."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + TIMEOUT_S
        while True:
            value = await read() if asyncio.iscoroutinefunction(read) else read()
            if predicate(value):
                return value
            assert loop.time() < deadline, f"timed out waiting for {what}"
            await asyncio.sleep(0.1)

    async def secured(user: str | None) -> Client:
        client = Client(live["endpoint"], timeout=TIMEOUT_S)
        client.application_uri = certificates.CLIENT_URI
        if user is not None:
            client.set_user(user)
            client.set_password(PASSWORD)
        sec = live["security"]
        await client.set_security(SecurityPolicyBasic256Sha256, str(sec.client_certificate),
                                  str(sec.client_private_key),
                                  server_certificate=str(sec.server_certificate))
        return client

    async def anonymous_write(target):
        async with await secured(None) as client:
            idx = await client.get_namespace_index(names.NAMESPACE_URI)
            rig = await client.nodes.objects.get_child([f"{idx}:{names.ROOT}"])
            setpoint = await rig.get_child([f"{idx}:Setpoints", f"{idx}:DownholePressureSetpoint"])
            with pytest.raises(ua.uaerrors.BadUserAccessDenied):
                await setpoint.write_value(target - 6.0e5)
            return await setpoint.read_value()

    async def session():
        async with await secured(OPERATOR) as client:
            idx = await client.get_namespace_index(names.NAMESPACE_URI)
            rig = await client.nodes.objects.get_child([f"{idx}:{names.ROOT}"])
            bhp = await rig.get_child([f"{idx}:Measurements", f"{idx}:DownholePressure"])
            first = await until(bhp.read_value, math.isfinite, "a measured BHP")
            assert PHYSICAL_BHP_PA[0] < first < PHYSICAL_BHP_PA[1], first
            unit = await (await bhp.get_child(["0:EngineeringUnits"])).read_value()
            assert unit.UnitId == names.UNITS["Pa"].unit_id

            changes = Changes()
            subscription = await client.create_subscription(100, changes)
            await subscription.subscribe_data_change(bhp)

            await until(lambda: {v for v in changes.values if math.isfinite(v)},
                        lambda values: len(values) >= 2, "the subscription to see BHP change")

            setpoint = await rig.get_child([f"{idx}:Setpoints", f"{idx}:DownholePressureSetpoint"])
            in_force = await until(setpoint.read_value, math.isfinite, "the setpoints in force")
            target = in_force + 3.0e5
            await setpoint.write_value(target)                                # valid: +3 bar
            await until(lambda: seen["setpoints"][-1].bhp_ref_pa if seen["setpoints"] else math.nan,
                        lambda v: abs(v - target) < 1.0, "the written BHP setpoint on /setpoints")
            await until(setpoint.read_value, lambda v: abs(v - target) < 1.0, "the setpoint read back")

            with pytest.raises(ua.UaStatusCodeError) as refused:
                await setpoint.write_value(7.2e7)                             # over fracture
            result = await (await rig.get_child([f"{idx}:{names.LAST_WRITE_RESULT}"])).read_value()
            after = await setpoint.read_value()

            level = await rig.get_child([f"{idx}:AutomationLevel"])
            await until(level.read_value, lambda v: v == "closed_loop", "the level in force")
            await level.write_value("advisory")
            await until(level.read_value, lambda v: v == "advisory", "advisory applied by the protection")
            with pytest.raises(ua.UaStatusCodeError) as bad_level:
                await level.write_value("autopilot")
            await subscription.delete()
            return refused.value, result, after, target, bad_level.value

    refused, result, after, target, bad_level = asyncio.run(session())
    assert abs(asyncio.run(anonymous_write(target)) - target) < 1.0          # unchanged
    assert refused.code == ua.StatusCodes.BadRequestNotAllowed
    assert "refused" in result and "fracture" in result, result
    assert abs(after - target) < 1.0                                         # unchanged
    assert abs(seen["setpoints"][-1].bhp_ref_pa - target) < 1.0
    assert bad_level.code == ua.StatusCodes.BadOutOfRange
    logged = lambda: [(e.code, e.text) for e in seen["events"] if e.text.startswith("[opcua]")]
    all_logged = lambda: (any(c == "operator_setpoints_accepted" for c, _ in logged())
                          and any(c == "operator_setpoints_refused" and "fracture" in t
                                  for c, t in logged())
                          and any(c == "request_refused"
                                  and "anonymous session (anonymous) may not write" in t
                                  for c, t in logged()))
    wait_for(all_logged, TIMEOUT_S,
             f"the gateway's accepted and refused writes on {topics.OPERATOR_EVENTS}")
