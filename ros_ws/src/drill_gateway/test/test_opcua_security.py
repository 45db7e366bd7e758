"""A secured OPC-UA gateway bound to every interface (0.0.0.0), without ROS, against
asyncua's own client: no None-policy session, anonymous sessions and viewers read but
their writes are refused (Bad status, nothing changes, the attempt recorded), an operator
writes over Basic256Sha256 SignAndEncrypt and Sign, a wrong password or an untrusted
client certificate gets no session, and a gateway other machines reach does not start
without security."""
import asyncio
import socket

import pytest
from asyncua import Client, ua
from asyncua.client import client as asyncua_client
from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256
from rig_testing import until

from drill_core import access
from drill_core.schema import ConfigError
from drill_gateway import certificates
from drill_gateway import opcua_names as names
from drill_gateway.opcua_gateway import Gateway
from drill_gateway.opcua_writes import Outcome

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

TIMEOUT_S = 20.0
PASSWORDS = {"olivia": "olivia-pass", "victor": "victor-pass"}
SETPOINT = ("Setpoints", "DownholePressureSetpoint")
IN_FORCE_PA = 6.85e7


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def security(tmp_path_factory):
    directory = tmp_path_factory.mktemp("security")
    sec = certificates.make(directory, [socket.gethostname(), "localhost", "127.0.0.1"])
    certificates.add_user(directory, "olivia", access.OPERATOR, PASSWORDS["olivia"])
    certificates.add_user(directory, "victor", access.VIEWER, PASSWORDS["victor"])
    return sec


@pytest.fixture(scope="module")
def served(security):
    handled, recorded = [], []

    def on_setpoint(variable, value):
        handled.append(value)
        return Outcome(None)

    port = free_port()
    gateway = Gateway(f"opc.tcp://0.0.0.0:{port}/drill-rig", on_setpoint,
                      lambda level: Outcome(None), security, on_refused=recorded.append)
    gateway.start()
    gateway.update("setpoints", {"bhp_ref_pa": IN_FORCE_PA})
    yield {"url": f"opc.tcp://127.0.0.1:{port}/drill-rig", "handled": handled,
           "recorded": recorded, "gateway": gateway}
    gateway.stop()


async def secured_client(url, sec, user=None, mode=ua.MessageSecurityMode.SignAndEncrypt,
                         certificate=None, private_key=None) -> Client:
    client = Client(url, timeout=TIMEOUT_S)
    client.application_uri = certificates.CLIENT_URI
    if user is not None:
        client.set_user(user)
        client.set_password(PASSWORDS.get(user, "not-the-password"))
    await client.set_security(SecurityPolicyBasic256Sha256,
                              str(certificate or sec.client_certificate),
                              str(private_key or sec.client_private_key),
                              server_certificate=str(sec.server_certificate), mode=mode)
    return client


async def setpoint_node(client):
    idx = await client.get_namespace_index(names.NAMESPACE_URI)
    rig = await client.nodes.objects.get_child([f"{idx}:{names.ROOT}"])
    node = await rig.get_child([f"{idx}:{part}" for part in SETPOINT])
    result = await rig.get_child([f"{idx}:{names.LAST_WRITE_RESULT}"])
    return node, result


def test_a_gateway_other_machines_reach_does_not_start_without_security():
    for host in ("0.0.0.0", "192.168.1.20"):
        with pytest.raises(ConfigError, match="reachable from other machines.*rig certs"):
            Gateway(f"opc.tcp://{host}:{free_port()}/drill-rig")
    Gateway(f"opc.tcp://127.0.0.1:{free_port()}/drill-rig")     # loopback: allowed open


def test_the_secured_gateway_offers_basic256sha256_only_and_a_none_client_gets_no_session(served):
    async def session():
        async with Client(served["url"], timeout=TIMEOUT_S) as discovery:
            return await discovery.get_endpoints()

    with pytest.raises(ua.UaError, match="No matching endpoints"):
        asyncio.run(session())
    endpoints = asyncio.run(_endpoints(served["url"]))
    assert {(e.SecurityPolicyUri, e.SecurityMode) for e in endpoints} == {
        (SecurityPolicyBasic256Sha256.URI, ua.MessageSecurityMode.SignAndEncrypt),
        (SecurityPolicyBasic256Sha256.URI, ua.MessageSecurityMode.Sign)}


async def _endpoints(url):
    client = Client(url, timeout=TIMEOUT_S)
    return await client.connect_and_get_server_endpoints()


def test_a_client_that_ignores_the_endpoints_is_served_nothing_on_an_unsecured_channel(
        served, monkeypatch):
    # a non-conforming client: a session over the None channel asyncua keeps for discovery
    monkeypatch.setattr(asyncua_client.Client, "find_endpoint",
                        staticmethod(lambda endpoints, mode, uri: endpoints[0]))

    async def session():
        client = Client(served["url"], timeout=TIMEOUT_S)
        client.set_user("olivia")
        client.set_password(PASSWORDS["olivia"])
        async with client:
            await setpoint_node(client)

    with pytest.raises(ua.uaerrors.BadUserAccessDenied):
        asyncio.run(session())
    assert served["handled"] == []


@pytest.mark.parametrize("user, who", [(None, "an anonymous session (anonymous)"),
                                       ("victor", "user victor (viewer)")])
def test_anonymous_sessions_and_viewers_read_but_a_write_is_refused_and_recorded(
        served, security, user, who):
    async def session():
        async with await secured_client(served["url"], security, user) as client:
            node, result = await setpoint_node(client)
            before = await until(node.read_value, lambda v: v == IN_FORCE_PA, TIMEOUT_S)
            with pytest.raises(ua.uaerrors.BadUserAccessDenied):
                await node.write_value(6.9e7)
            return before, await node.read_value(), await result.read_value()

    recorded_before = len(served["recorded"])
    before, after, result = asyncio.run(session())
    assert before == after == IN_FORCE_PA
    assert served["handled"] == []                           # no request reached the rig
    assert f"{who} may not write" in result
    assert served["recorded"][recorded_before:] == [result]  # the attempt, for the event log


@pytest.mark.parametrize("mode", [ua.MessageSecurityMode.SignAndEncrypt,
                                  ua.MessageSecurityMode.Sign])
def test_an_operator_writes_a_setpoint(served, security, mode):
    async def session():
        async with await secured_client(served["url"], security, "olivia", mode) as client:
            node, result = await setpoint_node(client)
            await node.write_value(6.9e7)
            return await result.read_value()

    handled_before = len(served["handled"])
    result = asyncio.run(session())
    assert served["handled"][handled_before:] == [6.9e7]
    assert result.startswith("accepted"), result


def test_a_wrong_password_gets_no_session(served, security):
    async def session():
        async with await secured_client(served["url"], security, "mallory"):
            pass

    with pytest.raises(ua.uaerrors.BadUserAccessDenied):
        asyncio.run(session())


def test_a_client_certificate_not_in_trusted_gets_no_session(served, security, tmp_path):
    stranger = certificates.make(tmp_path, ["localhost", "127.0.0.1"])   # not the server's trusted/

    async def session():
        client = await secured_client(served["url"], security, "olivia",
                                      certificate=stranger.client_certificate,
                                      private_key=stranger.client_private_key)
        async with client:
            pass

    with pytest.raises(ua.uaerrors.BadCertificateUntrusted):
        asyncio.run(session())
