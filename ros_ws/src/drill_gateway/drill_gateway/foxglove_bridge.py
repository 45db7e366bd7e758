"""Foxglove live view, the plain part: a Foxglove WebSocket server (foxglove-sdk) with one
channel per rig topic, forwarding each message's CDR bytes as they came off DDS.

Each channel carries the topic's ``ros2msg`` schema, the dependency-expanded definition
the recorder writes into the run's MCAP (drill_bag.mcap_io.message_definition), and
message encoding ``cdr``, so Foxglove decodes live data and a recording the same way and
one layout (config/foxglove/rig-layout.json) serves both. No rclpy here: the node
(drill_gateway.foxglove_node) discovers the topics and hands over the bytes.
"""
from __future__ import annotations

import foxglove

from drill_bag import mcap_io

HOST = "127.0.0.1"          # this machine only (docs/gateways.md)
DEFAULT_PORT = 8765         # Foxglove's usual port
SERVER_NAME = "drill-rig"
# not streamed: /clock (the stamps carry the time), and ROS's own log and parameter topics
EXCLUDED_TOPICS = frozenset({"/clock", "/rosout", "/parameter_events"})


def schema(type_name: str) -> foxglove.Schema:
    """The ros2msg schema of ROS type ``type_name`` ('pkg/msg/Type'), named as rosbag2
    names it."""
    return foxglove.Schema(name=type_name, encoding=mcap_io.SCHEMA_ENCODING,
                           data=mcap_io.message_definition(type_name).encode("utf-8"))


class Bridge:
    """A Foxglove WebSocket server on ``host:port`` (port 0: a free one) and its channels,
    one per topic; ``forward`` is safe from any thread."""

    def __init__(self, host: str = HOST, port: int = DEFAULT_PORT):
        if not 0 <= port <= 65535:
            raise ValueError(f"port {port}: expected 0..65535 (0: a free port)")
        self.host = host
        self._context = foxglove.Context()
        try:
            self._server = foxglove.start_server(name=SERVER_NAME, host=host, port=port,
                                                 context=self._context)
        except RuntimeError as err:      # the SDK's FoxgloveError: port in use, bad host
            raise RuntimeError(f"Foxglove server on {host}:{port}: {err} (--foxglove PORT "
                               "takes another port)") from err
        self._channels: dict[str, foxglove.Channel] = {}

    @property
    def port(self) -> int:
        return self._server.port

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    @property
    def topics(self) -> list[str]:
        return sorted(self._channels)

    def wants(self, topic: str) -> bool:
        """Whether ``topic`` should get a channel: streamed and not yet advertised."""
        return topic not in EXCLUDED_TOPICS and topic not in self._channels

    def add(self, topic: str, type_name: str) -> None:
        """Advertise ``topic`` of ROS type ``type_name``; raises LookupError (an unknown
        package), OSError or ValueError (from the schema) when its definition cannot be
        found."""
        self._channels[topic] = foxglove.Channel(
            topic, schema=schema(type_name), message_encoding=mcap_io.MESSAGE_ENCODING,
            context=self._context)

    def forward(self, topic: str, cdr: bytes) -> None:
        """Send one serialized message to the clients subscribed to ``topic``."""
        self._channels[topic].log(cdr)

    def close(self) -> None:
        for channel in self._channels.values():
            channel.close()
        self._server.stop()
