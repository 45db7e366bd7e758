"""WITS0 without DDS: record 01 frames read back by a parser written for the tests from
the public record layout (test/support/wits0_client.py), from the frame function and through the TCP server to two clients; bad addresses refused; a
client that goes away dropped. The live stream of a realtime run is in
test/test_gateways.py."""
import math
import socket

import pytest
from drill_msgs.msg import ActuatorFrame, RigMeasurement
from rig_testing import wait_for
from wits0_client import parse_frames

from drill_bag.well_log import LOG_TOPICS, RigSnapshot
from drill_gateway import wits0
from drill_ros import graph

NS = 1_000_000_000
STAMP_NS = 1_764_806_400 * NS + 250_000_000      # 2025-12-04 00:00:00.25 UTC


def snapshot(string_flow_valid=True):
    m = RigMeasurement(block_position_m=2.0, choke_dp_pa=2.5e6, bhp_pa=6.85e7,
                       string_flow_m3s=0.0166 if string_flow_valid else math.nan,
                       string_flow_valid=string_flow_valid, return_flow_m3s=0.0170,
                       pit_volume_m3=40.5, bpp_flow_m3s=0.0, hook_load_n=1.25e6)
    m.header.stamp.sec, m.header.stamp.nanosec = divmod(STAMP_NS, NS)
    pump = ActuatorFrame(actuator="mud_pump", output=[1.05e7] * 10, sample_period_s=0.01)
    pump.header.stamp = m.header.stamp
    return RigSnapshot(m, {"mud_pump": pump}, STAMP_NS, 3607.8, 40.0)


def test_a_frame_carries_record_01_items_in_wits_metric_units():
    [items] = parse_frames(wits0.frame(snapshot(), "case2-with-a-long-name").encode())
    assert items["0101"] == "case2-with-a-lon"                 # 16 characters
    assert (items["0105"], items["0106"]) == ("251204", "000000")
    assert float(items["0108"]) == pytest.approx(3605.8)      # bit depth [m]
    assert float(items["0114"]) == pytest.approx(1250.0)      # hook load [kN]
    assert float(items["0121"]) == pytest.approx(10500.0)     # SPP [kPa]
    assert float(items["0122"]) == pytest.approx(2500.0)      # choke pressure [kPa]
    assert float(items["0126"]) == pytest.approx(40.5)
    assert float(items["0127"]) == pytest.approx(0.5)
    assert float(items["0129"]) == pytest.approx(1020.0)      # flow out [L/min]
    assert float(items["0130"]) == pytest.approx(996.0)
    assert float(items["0141"]) == pytest.approx(68500.0)     # BHP [kPa]
    assert float(items["0143"]) == pytest.approx(24.0)        # delta flow [L/min]
    assert "0144" not in items                                # no choke frame: no opening


def test_an_item_without_a_value_is_left_out():
    [items] = parse_frames(wits0.frame(snapshot(string_flow_valid=False), "w").encode())
    assert "0130" not in items and "0143" not in items and "0129" in items


def test_each_second_of_the_samples_stamps_gets_one_frame_whatever_the_wall_clock_does():
    pacer = wits0.RecordPacer(1.0)
    # a lagging realtime run: looked at 0.1 s apart in wall time, the samples advance
    # 0.05 s, stall, then jump 2.3 s
    stamps_s = [27.95, 28.0, 28.05, 28.05, 28.95, 29.0, 31.3, 31.35, 32.0]
    sent = [t for t in stamps_s if pacer.due(round(t * NS))]
    assert sent == [27.95, 28.0, 29.0, 31.3, 32.0]


@pytest.mark.parametrize("period_s", [0.0, -1.0, float("nan")])
def test_a_period_that_is_not_positive_is_refused(period_s):
    with pytest.raises(ValueError, match="period_s"):
        wits0.RecordPacer(period_s)


def test_the_server_sends_each_frame_to_every_client_and_drops_one_that_left():
    server = wits0.Wits0Server("127.0.0.1:0")
    try:
        clients = [socket.create_connection(("127.0.0.1", server.port), timeout=10)
                   for _ in range(2)]
        wait_for(lambda: server.clients == 2, 60.0, "the server to accept both clients")
        text = wits0.frame(snapshot(), "w")
        server.send(text)
        server.send(text)
        for client in clients:
            data = b""
            while data.count(b"!!\r\n") < 2:
                data += client.recv(4096)
            assert len(parse_frames(data)) == 2
        clients[0].close()
        for _ in range(50):                     # the closed peer fails a send within a few
            server.send(text)
            if server.clients == 1:
                break
        assert server.clients == 1
    finally:
        server.close()


@pytest.mark.parametrize("address", ["localhost", ":80", "host:port", "host:70000"])
def test_a_bad_address_is_refused_with_the_form_it_needs(address):
    with pytest.raises(ValueError, match="must be HOST:PORT, port 0-65535"):
        wits0.parse_address(address)


def test_the_graph_declares_the_topics_the_log_reads():
    assert set(graph.BY_NAME["wits0_gateway"].subscribes) == set(LOG_TOPICS)
