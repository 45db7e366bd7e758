"""Sensor faults of a scenario applied to the plant's samples (plain Python): dropout,
frozen value, bias, drift, noise burst, and single NaN, inf or spike samples, each on one
channel (drill_core.events). A fault on one channel leaves the others untouched."""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from drill_core.events import SINGLE, ScenarioEvent, EVENT_KINDS


class SensorFaults:
    """The plant's sensor events, applied sample by sample in time order."""

    def __init__(self, events: tuple[ScenarioEvent, ...], seed: int):
        self.events = tuple(e for e in events if EVENT_KINDS[e.kind].owner == "plant"
                            and e.target)
        self._fired: set[int] = set()                 # single-sample events already applied
        self._frozen: dict[int, float] = {}           # frozen events: the value they hold
        self._last: dict[str, float] = {}             # each channel's last delivered value
        self._rng = np.random.default_rng(np.random.SeedSequence([seed, 0x5E45]))

    def apply(self, time_s: float, sample):
        """``sample`` (a dataclass with the channel fields) with the faults acting at
        ``time_s``."""
        changes = {}
        for i, event in enumerate(self.events):
            channel = event.target
            value = changes.get(channel, getattr(sample, channel))
            if EVENT_KINDS[event.kind].timing == SINGLE:
                if i in self._fired or time_s + 1e-9 < event.time_s:
                    continue
                self._fired.add(i)
            elif not event.active(time_s):
                continue
            changes[channel] = self._faulted(i, event, value, time_s)
        faulted = dataclasses.replace(sample, **changes) if changes else sample
        for channel in {e.target for e in self.events}:
            self._last[channel] = getattr(faulted, channel)
        return faulted

    def _faulted(self, i: int, event: ScenarioEvent, value: float, time_s: float) -> float:
        if event.kind == "frozen":
            return self._frozen.setdefault(i, self._last.get(event.target, value))
        if event.kind == "noise_burst":
            return value + event.value * float(self._rng.standard_normal())
        return _EFFECTS[event.kind](value, event, time_s)


# value, event, time -> the faulted value (frozen and noise_burst keep state: above)
_EFFECTS = {
    "dropout": lambda value, event, time_s: math.nan,
    "nan": lambda value, event, time_s: math.nan,
    "inf": lambda value, event, time_s: math.inf,
    "bias": lambda value, event, time_s: value + event.value,
    "spike": lambda value, event, time_s: value + event.value,
    "drift": lambda value, event, time_s: value + event.value * (time_s - event.time_s),
}
