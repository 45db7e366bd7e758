"""The OPC-UA server without ROS: browse by name, engineering units, values pushed from
another thread reaching a subscription, and writes gated by the validating function (a
refusal is a Bad status, its reason in Rig/LastWriteResult, the value unchanged); Part 8
analog items (EURange, EngineeringUnits), the message stamp as SourceTimestamp, and the
status of a variable before its first value, of a non-finite one and of a silent source."""
import asyncio
import math
import socket
import threading

import pytest
from asyncua import Client, ua
from rig_testing import until

from drill_gateway import opcua_names as names
from drill_gateway.opcua_gateway import Gateway, check_endpoint
from drill_gateway.opcua_writes import BAD_NOT_ALLOWED, Outcome

TIMEOUT_S = 20.0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def served():
    writes = []

    def on_setpoint(variable, value):
        writes.append((variable.name, value))
        return Outcome(None) if value < 7.0e7 else Outcome(BAD_NOT_ALLOWED, "above the fracture pressure")

    gateway = Gateway(f"opc.tcp://127.0.0.1:{free_port()}/drill-rig", on_setpoint,
                      lambda level: Outcome(None))
    gateway.start()
    yield gateway, writes
    gateway.stop()


async def child(client, *path):
    idx = await client.get_namespace_index(names.NAMESPACE_URI)
    return await client.nodes.objects.get_child([f"{idx}:{p}" for p in path])


def test_browse_read_subscribe_and_gated_writes(served):
    gateway, writes = served

    class Changes:
        def __init__(self):
            self.values, self.events = [], []

        def datachange_notification(self, node, value, data):
            self.values.append(value)

        def event_notification(self, event):
            self.events.append(event.Message.Text)

    async def session():
        async with Client(gateway.endpoint) as client:
            bhp = await child(client, "Rig", "Measurements", "DownholePressure")
            unit = await (await bhp.get_child(["0:EngineeringUnits"])).read_value()
            assert (unit.UnitId, unit.DisplayName.Text) == (names.UNITS["Pa"].unit_id, "Pa")
            described = next(v for v in names.VARIABLES
                             if v.path == ("Rig", "Measurements", "DownholePressure"))
            assert (await bhp.read_description()).Text == described.description
            changes = Changes()
            subscription = await client.create_subscription(50, changes)
            await subscription.subscribe_data_change(bhp)
            await subscription.subscribe_events()          # the Server object's events
            threading.Thread(target=gateway.update,
                             args=("measurement", {"bhp_pa": 6.85e7, "choke_dp_pa": 2e6})).start()
            assert await until(bhp.read_value, lambda v: v == 6.85e7, TIMEOUT_S,
                               "BHP 685 bar") == 6.85e7
            async def notified():
                return list(changes.values)
            await until(notified, lambda v: 6.85e7 in v, TIMEOUT_S, "the change notified")
            gateway.update("setpoints", {"bhp_ref_pa": 6.85e7})
            setpoint = await child(client, "Rig", "Setpoints", "DownholePressureSetpoint")
            await until(setpoint.read_value, lambda v: v == 6.85e7, TIMEOUT_S,
                        "the setpoint in force")

            await setpoint.write_value(6.88e7)
            assert await setpoint.read_value() == 6.88e7
            with pytest.raises(ua.UaStatusCodeError) as refused:
                await setpoint.write_value(7.2e7)
            assert refused.value.code == ua.StatusCodes.BadRequestNotAllowed
            assert await setpoint.read_value() == 6.88e7                 # unchanged
            result = await (await child(client, "Rig", "LastWriteResult")).read_value()
            assert "refused" in result and "above the fracture pressure" in result

            async def events():
                return list(changes.events)
            assert result in await until(events, lambda e: result in e, TIMEOUT_S,
                                         "the refusal's event")
            with pytest.raises(ua.UaStatusCodeError) as mistyped:
                await setpoint.write_value(ua.Variant(5, ua.VariantType.Int32))
            assert mistyped.value.code == ua.StatusCodes.BadTypeMismatch
            with pytest.raises(ua.UaStatusCodeError) as read_only:
                await bhp.write_value(1.0)
            assert read_only.value.code == ua.StatusCodes.BadUserAccessDenied
            await subscription.delete()

    asyncio.run(session())
    assert writes == [("DownholePressureSetpoint", 6.88e7), ("DownholePressureSetpoint", 7.2e7)]
    assert gateway.writes == {"accepted": 1, "refused": 2}


def test_analog_items_source_timestamps_and_the_status_of_bad_or_silent_values(served):
    gateway, _ = served
    gateway.stale_after_s = 0.5
    stamp_ns = 1_764_806_400 * 10**9 + 250_000_000

    async def session():
        async with Client(gateway.endpoint) as client:
            bhp = await child(client, "Rig", "Measurements", "DownholePressure")

            async def read():
                return await bhp.read_data_value(raise_on_bad_status=False)
            first = await read()
            assert first.StatusCode.value == ua.StatusCodes.BadWaitingForInitialData
            assert (await bhp.read_type_definition()) == ua.NodeId(ua.ObjectIds.AnalogItemType)
            eu_range = await (await bhp.get_child(["0:EURange"])).read_value()
            assert (eu_range.Low, eu_range.High) == (0.0, 1.0e8)
            units = await (await bhp.get_child(["0:EngineeringUnits"])).read_value()
            assert units.UnitId == names.UNITS["Pa"].unit_id
            gateway.update("measurement", {"bhp_pa": 6.85e7}, stamp_ns)
            good = await until(read, lambda dv: dv.Value.Value == 6.85e7, TIMEOUT_S, "the BHP")
            assert good.StatusCode.is_good()
            assert good.SourceTimestamp.timestamp() == pytest.approx(stamp_ns / 1e9, abs=1e-6)
            gateway.update("measurement", {"bhp_pa": math.nan}, stamp_ns + 10**8)
            kept = await until(read, lambda dv: not dv.StatusCode.is_good(), TIMEOUT_S,
                               "the non-finite BHP's status")
            assert kept.StatusCode.value == ua.StatusCodes.UncertainLastUsableValue
            assert kept.Value.Value == 6.85e7                 # the last usable value
            await until(read, lambda dv: dv.StatusCode.value == ua.StatusCodes.BadNoCommunication,
                        TIMEOUT_S, "BadNoCommunication once the measurements go silent")
            gateway.update("measurement", {"bhp_pa": 6.86e7}, stamp_ns + 10**9)
            await until(read, lambda dv: dv.StatusCode.is_good() and dv.Value.Value == 6.86e7,
                        TIMEOUT_S, "Good again once they speak")

    asyncio.run(session())


def test_an_endpoint_that_is_not_opc_tcp_host_port_is_refused_with_the_form():
    assert check_endpoint("opc.tcp://localhost:4840/drill-rig")
    for bad in ("http://127.0.0.1:4840/", "opc.tcp://127.0.0.1/drill-rig", "127.0.0.1:4840"):
        with pytest.raises(ValueError, match="expected opc.tcp://HOST:PORT/PATH"):
            check_endpoint(bad)
    with pytest.raises(ValueError, match="source 'truth'"):
        Gateway().update("truth", {})


def test_a_taken_port_fails_the_start_naming_the_endpoint(served):
    gateway, _ = served
    with pytest.raises(RuntimeError, match=f"server on {gateway.endpoint} could not start"):
        Gateway(gateway.endpoint).start()
