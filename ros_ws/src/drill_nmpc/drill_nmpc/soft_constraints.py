"""The NMPC's soft constraints (paper eqs. 52-53), declared once.

Each row of ``SOFT_CONSTRAINTS`` names the constrained quantity (SI, from one stage's
values), whether it is a band whose edges are set per solve or a margin kept above zero,
the unit of its slack variable inside the OCP, its penalty weight, and when it applies:
on the stages with inputs (0..N-1) or on the path (1..N-1); dropped in the relaxed retry
of the fallback policy (paper Alg. 3 keeps velocity, string pressure and the input
limits); dropped while the mud pump is off; built only into the OCP of a multi-stand
trip, whose rig floor takes a stand's move as done only with the string at rest near the
stand's end (an overshoot is paid for in the time it takes to creep back). The
transcription and the solve-time bounds read only this table.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from drill_nmpc.prediction_model import choke_capacity, string_pressure_margin


@dataclass(frozen=True)
class StageValues:
    """What a soft constraint may read at one stage (CasADi expressions, SI)."""
    em: Any          # the estimation model
    model: Any       # the prediction model
    x: Any           # prediction state
    u: Any           # input applied over the stage
    full: list       # the estimation model's state (x with the frozen parameters)
    y: list          # tracked outputs [block position, choke dp, BHP], BHP with its bias


@dataclass(frozen=True)
class SoftConstraint:
    name: str
    value: Callable[[StageValues], Any]   # the constrained quantity [SI]
    band: bool                            # True: within edges set per solve; False: >= 0
    slack_unit: float                     # SI value of one slack unit
    weight: str                           # Nmpc field of its penalty weight T
    on_input_stages: bool                 # stages 0..N-1 (else the path, 1..N-1)
    relaxed_on_fallback: bool             # dropped in the relaxed retry
    needs_circulation: bool = False       # dropped while the mud pump is off
    floor_trip_only: bool = False         # only in a multi-stand trip's OCP


SOFT_CONSTRAINTS = (
    SoftConstraint("velocity", lambda s: s.x[s.em.velocity], True, 0.01, "slack_weight_velocity",
                   False, False),
    SoftConstraint("bhp_band", lambda s: s.y[2], True, 1.0e4, "slack_weight_bhp", False, True),
    SoftConstraint("choke_dp_band", lambda s: s.y[1], True, 1.0e5, "slack_weight_choke_dp",
                   False, True),
    SoftConstraint("string_pressure", lambda s: string_pressure_margin(s.em, s.full), False,
                   1.0e5, "slack_weight_string_pressure", False, False, needs_circulation=True),
    SoftConstraint("choke_capacity",
                   lambda s: choke_capacity(s.em, s.y[1]) - s.model.choke_flow(s.x, s.u, s.em.bulk_modulus_of(s.full)),
                   False,
                   1.0e-3, "slack_weight_choke_capacity", True, True),
    SoftConstraint("stand_end", lambda s: s.x[s.em.position], True, 0.01,
                   "slack_weight_stand_end", False, True, floor_trip_only=True),
)
BY_NAME = {c.name: c for c in SOFT_CONSTRAINTS}
SLACK_NAMES = tuple(c.name for c in SOFT_CONSTRAINTS)
SLACK_UNITS = {c.name: c.slack_unit for c in SOFT_CONSTRAINTS}


def soft_constraints(floor_trip: bool = False) -> tuple[SoftConstraint, ...]:
    """The rows of an OCP: a multi-stand trip's (``floor_trip``) or any other's."""
    return tuple(c for c in SOFT_CONSTRAINTS if floor_trip or not c.floor_trip_only)
