"""A WITS Level 0 reader written for the tests from the public record layout, not from
the rig's code: a frame is a line ``&&``, lines of a four-digit item (record, item) and
its value, a line ``!!``; lines end in CR LF."""
from __future__ import annotations


def parse_frames(data: bytes) -> list[dict[str, str]]:
    """Every whole frame in ``data``: item -> value text."""
    frames, current = [], None
    for line in data.decode("ascii").split("\r\n"):
        if line == "&&":
            current = {}
        elif line == "!!" and current is not None:
            frames.append(current)
            current = None
        elif current is not None and len(line) >= 4 and line[:4].isdigit():
            current[line[:4]] = line[4:]
    return frames
