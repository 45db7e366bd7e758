"""The well's surface flow balance (docs/model.md, formation and pit): one definition of
the MPD engineer's delta flow, read by the kick detector and the well log."""
from __future__ import annotations


def delta_flow_m3s(sample) -> float:
    """Flow out less all flow in [m^3/s]: the choke line's return flow less the string's
    and the back-pressure pump's (which leaves through the choke too). ``sample``: any
    object with ``return_flow_m3s``, ``string_flow_m3s`` and ``bpp_flow_m3s`` (a
    RigMeasurement, the kick detector's FlowSample)."""
    return sample.return_flow_m3s - sample.string_flow_m3s - sample.bpp_flow_m3s
