"""A fast-mode run's progress, from the plant's log to the launcher's terminal: the plant
prints a marker line every ``EVERY_S`` of simulated time, ``rig run`` reads the last one
of the plant process's log (drill_bringup.runs) and shows simulated time and the real-time
factor as it goes."""
from __future__ import annotations

from pathlib import Path

KEY = "SIMULATED_S"
EVERY_S = 10.0              # simulated seconds between the plant's marker lines
TAIL_BYTES = 4096           # how much of the log's end the reader looks at


def marker(simulated_s: float, duration_s: float) -> str:
    """The plant's line: ``SIMULATED_S <t> <of>``."""
    return f"{KEY} {simulated_s:.1f} {duration_s:.1f}"


class PlantProgress:
    """The plant's marker lines: one on stdout (its log) every EVERY_S of simulated time."""

    def __init__(self, sensor_period_s: float, duration_s: float):
        self.every = max(int(round(EVERY_S / sensor_period_s)), 1)    # frames between lines
        self.sensor_period_s, self.duration_s = sensor_period_s, duration_s

    def frame_done(self, k: int) -> None:
        """Frame ``k`` (1, 2, ...) is integrated."""
        if k % self.every == 0:
            print(marker(k * self.sensor_period_s, self.duration_s), flush=True)


def last_marker(log: Path) -> tuple[float, float] | None:
    """(simulated s, scenario s) of the last marker in ``log``; None before the first."""
    try:
        with open(log, "rb") as f:
            f.seek(0, 2)
            f.seek(max(f.tell() - TAIL_BYTES, 0))
            tail = f.read().decode(errors="replace")
    except OSError:
        return None
    for line in reversed(tail.splitlines()):
        parts = line.split()
        if len(parts) == 3 and parts[0] == KEY:
            try:
                return float(parts[1]), float(parts[2])
            except ValueError:
                return None
    return None
