"""The Foxglove bridge's server: channels with the recorder's ros2msg schemas, CDR bytes
forwarded as they are, decoded by a client speaking the Foxglove WebSocket protocol."""
import asyncio
import struct

import pytest
from drill_msgs.msg import RigMeasurement
from foxglove_client import FoxgloveClient
from rclpy.serialization import deserialize_message, serialize_message

from drill_bag import mcap_io
from drill_gateway.foxglove_bridge import Bridge

TOPIC, TYPE = "/rig/measurement", "drill_msgs/msg/RigMeasurement"


@pytest.fixture
def bridge():
    b = Bridge(port=0)
    yield b
    b.close()


def test_a_client_gets_the_schema_and_decodes_a_forwarded_message(bridge):
    bridge.add(TOPIC, TYPE)
    sent = RigMeasurement(bhp_pa=6.85e7, choke_dp_pa=2.0e6, block_position_m=1.5)
    sent.header.stamp.sec = 12

    async def session():
        async with FoxgloveClient(bridge.url) as client:
            await client.wait_for_channels([TOPIC], 10.0)
            await client.subscribe(TOPIC)
            for _ in range(200):        # until the server has taken the subscription
                bridge.forward(TOPIC, serialize_message(sent))
                try:
                    return client, await client.next_message(0.05)
                except TimeoutError:
                    continue
            raise AssertionError("no message reached the client")

    client, (topic, _, payload) = asyncio.run(session())
    channel = client.channels[TOPIC]
    assert client.server_info["name"] == "drill-rig"
    assert (channel["encoding"], channel["schemaEncoding"], channel["schemaName"]) == \
        ("cdr", "ros2msg", TYPE)
    assert channel["schema"] == mcap_io.message_definition(TYPE)    # as in the MCAP
    got = deserialize_message(payload, RigMeasurement)
    assert topic == TOPIC
    assert (got.bhp_pa, got.choke_dp_pa, got.block_position_m, got.header.stamp.sec) == \
        (6.85e7, 2.0e6, 1.5, 12)


def test_the_clock_and_ros_log_topics_and_repeats_are_not_streamed(bridge):
    assert not bridge.wants("/clock") and not bridge.wants("/rosout")
    assert bridge.wants(TOPIC)
    bridge.add(TOPIC, TYPE)
    assert not bridge.wants(TOPIC) and bridge.topics == [TOPIC]


def test_an_unknown_type_is_refused_with_its_name(bridge):
    with pytest.raises((OSError, ValueError, LookupError), match="no_such_pkg"):
        bridge.add("/x", "no_such_pkg/msg/Nothing")
    with pytest.raises(ValueError, match="port 70000"):
        Bridge(port=70000)
    with pytest.raises(RuntimeError, match=f"127.0.0.1:{bridge.port}: .*in use"):
        Bridge(port=bridge.port)


CLIENT_MESSAGE_DATA, SERVICE_CALL_REQUEST = 0x01, 0x02     # client-to-server binary opcodes


def test_the_bridge_is_read_only_a_clients_publish_service_call_and_parameters_are_refused(bridge):
    bridge.add(TOPIC, TYPE)

    async def session():
        async with FoxgloveClient(bridge.url) as client:
            await client.wait_for_channels([TOPIC], 10.0)
            answers = []
            for frame in (
                    {"op": "advertise", "channels": [{"id": 7, "topic": "/setpoints", "encoding": "cdr",
                                                      "schemaName": "drill_msgs/msg/Setpoints"}]},
                    bytes([CLIENT_MESSAGE_DATA]) + struct.pack("<I", 7) + b"\x00\x01\x00\x00",
                    bytes([SERVICE_CALL_REQUEST]) + struct.pack("<III", 1, 1, 3) + b"cdr\x00\x01\x00\x00",
                    {"op": "setParameters", "parameters": [{"name": "bhp_ref_pa", "value": 7.2e7}]}):
                await client.send(frame)
                answers.append(await client.next_answer(10.0))
            return client.server_info, answers

    info, (advertise, publish, call, parameters) = asyncio.run(session())
    assert info["capabilities"] == []          # no clientPublish, services, parameters
    assert (advertise["op"], advertise["level"]) == ("status", 2)     # 2: error
    assert "clientPublish" in advertise["message"]
    assert publish["op"] == "status" and "Unknown channel" in publish["message"]
    assert call["op"] == "serviceCallFailure" and "services" in call["message"]
    assert parameters["op"] == "status" and "parameters" in parameters["message"]
