"""WITS Level 0 out: the rig's record 01 (general time-based) as the ASCII frames a rig
data system reads, served to every client of a TCP port (``rig run ... --wits0``;
docs/gateways.md). Plain Python (no rclpy).

A frame is ``&&`` CR LF, one line per item (its four digits, record and item, then the
value), ``!!`` CR LF. Items: 0101 well identifier, 0105 date (YYMMDD) and 0106 time
(HHMMSS) of the sample's stamp in UTC, then the channels of drill_bag.well_log in their
WITS metric units (an item without a value, such as the flow in while the pump is off,
is left out of that frame).
"""
from __future__ import annotations

import math
import socket
import threading
from datetime import datetime, timezone

from drill_bag.well_log import CHANNELS, RigSnapshot

DEFAULT_ADDRESS = "127.0.0.1:11000"
WELL_ID_LENGTH = 16                 # item 0101 is 16 characters (type A)
START, END, EOL = "&&", "!!", "\r\n"


def parse_address(address: str) -> tuple[str, int]:
    """``HOST:PORT`` (port 0: a free one) as (host, port); a bad one is a ValueError
    that says why."""
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(f"WITS0 address {address!r}: must be HOST:PORT, port 0-65535")
    return host, int(port)


class RecordPacer:
    """Which samples get a frame: the first of each record period of the samples' own
    stamps, so no two frames carry the same period, however the gateway's wall clock
    and the rig's clock drift apart (a realtime run that lags, a fast run)."""

    def __init__(self, period_s: float):
        if not period_s > 0.0:
            raise ValueError(f"WITS0 period_s {period_s}: must be > 0 s")
        self.period_ns = round(period_s * 1e9)
        self._last_period = None

    def due(self, stamp_ns: int) -> bool:
        """True (and the period taken) if ``stamp_ns`` is in a later period than the
        last frame's."""
        period = stamp_ns // self.period_ns
        if self._last_period is not None and period <= self._last_period:
            return False
        self._last_period = period
        return True


def frame(snapshot: RigSnapshot, well_id: str) -> str:
    """The record 01 frame of one snapshot."""
    when = datetime.fromtimestamp(snapshot.stamp_ns / 1e9, tz=timezone.utc)
    lines = [START, f"0101{well_id[:WELL_ID_LENGTH]}", f"0105{when:%y%m%d}",
             f"0106{when:%H%M%S}"]
    for channel in CHANNELS:
        value = channel.value(snapshot)
        if math.isfinite(value):
            lines.append(f"{channel.wits_item}{value:.2f}")
    lines.append(END)
    return EOL.join(lines) + EOL


class Wits0Server:
    """A TCP server that sends each frame to every connected client; a client that
    goes away is dropped, and nothing a client sends is read."""

    def __init__(self, address: str):
        host, port = parse_address(address)
        self._listener = socket.create_server((host, port))
        self.host, self.port = host, self._listener.getsockname()[1]
        self._clients: list[socket.socket] = []
        self._lock = threading.Lock()
        self.frames_sent = 0
        self._thread = threading.Thread(target=self._accept, daemon=True)
        self._thread.start()

    @property
    def address(self) -> str:
        return f"{self.host}:{self.port}"

    @property
    def clients(self) -> int:
        with self._lock:
            return len(self._clients)

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:                  # closed
                return
            client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            client.settimeout(1.0)           # a client that stops reading is dropped
            with self._lock:
                self._clients.append(client)

    def send(self, text: str) -> None:
        """Send one frame to every client."""
        data = text.encode("ascii")
        with self._lock:
            for client in list(self._clients):
                try:
                    client.sendall(data)
                except OSError:
                    client.close()
                    self._clients.remove(client)
            self.frames_sent += 1

    def close(self) -> None:
        self._listener.close()
        with self._lock:
            for client in self._clients:
                client.close()
            self._clients.clear()
