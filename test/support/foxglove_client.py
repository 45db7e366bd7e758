"""A minimal Foxglove WebSocket client for the tests (the protocol the Foxglove app
speaks): serverInfo and advertise in, subscribe out, binary messageData frames in; any
other frame out as it is, and the server's other answers (status, failures) in."""
from __future__ import annotations

import asyncio
import json
import struct

import websockets

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
MESSAGE_DATA = 0x01      # opcode, then uint32 subscription id, uint64 timestamp, payload


class FoxgloveClient:
    """``async with FoxgloveClient(url) as client``: ``channels`` holds what the server
    advertised (topic -> channel dict)."""

    def __init__(self, url: str):
        self.url = url
        self.server_info: dict | None = None
        self.channels: dict[str, dict] = {}
        self.answers: list[dict] = []            # other JSON ops the server sent, in order
        self._subscriptions: dict[int, str] = {}
        self._ws = None

    async def __aenter__(self):
        self._ws = await websockets.connect(self.url, subprotocols=SUBPROTOCOLS)
        return self

    async def __aexit__(self, *exc):
        await self._ws.close()

    async def _receive(self, timeout_s: float):
        frame = await asyncio.wait_for(self._ws.recv(), timeout_s)
        if isinstance(frame, str):
            message = json.loads(frame)
            if message["op"] == "serverInfo":
                self.server_info = message
            elif message["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in message["channels"]})
            else:
                self.answers.append(message)
            return None
        return frame

    async def send(self, frame: dict | bytes) -> None:
        """One frame as it is: a JSON op (a dict) or a binary one."""
        await self._ws.send(json.dumps(frame) if isinstance(frame, dict) else frame)

    async def next_answer(self, timeout_s: float) -> dict:
        """The next JSON message that is not serverInfo or advertise (status, failures)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while not self.answers:
            left = deadline - loop.time()
            if left <= 0:
                raise TimeoutError(f"no answer within {timeout_s} s")
            await self._receive(left)
        return self.answers.pop(0)

    async def wait_for_channels(self, topics, timeout_s: float) -> None:
        """Receive until every topic in ``topics`` is advertised."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while not set(topics) <= set(self.channels):
            left = deadline - loop.time()
            if left <= 0:
                raise TimeoutError(f"not advertised within {timeout_s} s: "
                                   f"{sorted(set(topics) - set(self.channels))}")
            await self._receive(left)

    async def subscribe(self, topic: str) -> int:
        sub_id = len(self._subscriptions) + 1
        self._subscriptions[sub_id] = topic
        await self._ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": sub_id, "channelId": self.channels[topic]["id"]}]}))
        return sub_id

    async def next_message(self, timeout_s: float) -> tuple[str, int, bytes]:
        """The next messageData frame: (topic, receive time ns, payload)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while True:
            left = deadline - loop.time()
            if left <= 0:
                raise TimeoutError(f"no message within {timeout_s} s")
            frame = await self._receive(left)
            if frame is not None and frame[0] == MESSAGE_DATA:
                sub_id, stamp_ns = struct.unpack_from("<IQ", frame, 1)
                return self._subscriptions[sub_id], stamp_ns, bytes(frame[13:])
