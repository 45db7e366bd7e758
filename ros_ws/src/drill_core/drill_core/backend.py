"""Array namespaces so one model definition evaluates on numpy and on CasADi symbols.

Model code receives ``xp`` (``NUMPY`` or ``CASADI``) and uses only the functions
below plus + - * / **. With numpy, a state entry may be a row of values (one per
sigma point), so one call evaluates all sigma points at once. :func:`table` calls a
tabulated 1-D function (a CasADi interpolant of values on ``grid``) in a namespace.
"""
from __future__ import annotations

from types import SimpleNamespace

import casadi as ca
import numpy as np

from drill_core.table_tape import table_call


def _np_table(function, v, grid):
    v = np.asarray(v, dtype=float)
    return np.asarray(function(v.reshape(1, -1)), dtype=float).reshape(v.shape)


def _np_stack(items):
    return np.stack([np.broadcast_to(np.asarray(i, dtype=float), np.broadcast(*items).shape)
                     for i in items])


NUMPY = SimpleNamespace(
    name="numpy",
    sqrt=np.sqrt, fabs=np.abs, tanh=np.tanh, log=np.log, exp=np.exp,
    fmax=np.maximum, fmin=np.minimum, sign=np.sign,
    if_else=lambda cond, a, b: np.where(cond, a, b),
    stack=_np_stack,
    table=_np_table,
)

CASADI = SimpleNamespace(
    name="casadi",
    sqrt=ca.sqrt, fabs=ca.fabs, tanh=ca.tanh, log=ca.log, exp=ca.exp,
    fmax=ca.fmax, fmin=ca.fmin, sign=ca.sign,
    if_else=ca.if_else,
    stack=lambda items: ca.vertcat(*items),
    table=lambda function, v, grid: table_call(function, v),
)


def table(xp, function, v, grid):
    """``function`` (a 1-D CasADi interpolant tabulated on ``grid``) at ``v``: the namespace's
    ``table`` (a namespace that cannot call a CasADi function tabulates it again from
    ``grid``: drill_nmpc.peer_gekko), numpy's for the numpy module used as a namespace."""
    return getattr(xp, "table", _np_table)(function, v, grid)


def clip(xp, value, lo, hi):
    """Clamp ``value`` to [lo, hi] in either namespace."""
    return xp.fmin(xp.fmax(value, lo), hi)
