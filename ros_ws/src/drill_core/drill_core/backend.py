"""Array namespaces so one model definition evaluates on numpy and on CasADi symbols.

Model code receives ``xp`` (``NUMPY`` or ``CASADI``) and uses only the functions
below plus + - * / **. With numpy, a state entry may be a row of values (one per
sigma point), so one call evaluates all sigma points at once.
"""
from __future__ import annotations

from types import SimpleNamespace

import casadi as ca
import numpy as np


def _np_stack(items):
    return np.stack([np.broadcast_to(np.asarray(i, dtype=float), np.broadcast(*items).shape)
                     for i in items])


NUMPY = SimpleNamespace(
    name="numpy",
    sqrt=np.sqrt, fabs=np.abs, tanh=np.tanh, log=np.log, exp=np.exp,
    fmax=np.maximum, fmin=np.minimum, sign=np.sign,
    if_else=lambda cond, a, b: np.where(cond, a, b),
    stack=_np_stack,
)

CASADI = SimpleNamespace(
    name="casadi",
    sqrt=ca.sqrt, fabs=ca.fabs, tanh=ca.tanh, log=ca.log, exp=ca.exp,
    fmax=ca.fmax, fmin=ca.fmin, sign=ca.sign,
    if_else=ca.if_else,
    stack=lambda items: ca.vertcat(*items),
)


def clip(xp, value, lo, hi):
    """Clamp ``value`` to [lo, hi] in either namespace."""
    return xp.fmin(xp.fmax(value, lo), hi)
