"""Tables (1-D CasADi interpolants) called inside a symbolic expression, recorded so that
the expression's Jacobian evaluates each table's slope once per call.

CasADi's automatic differentiation of an SX expression differentiates a call node once
per seed direction, so a Jacobian with many columns calls each table many times (the
NMPC's prediction step: docs/experiments/2026-12-05-nmpc-jacobian.md). Built under a
:class:`TableTape`, an
expression gets a fresh symbol in place of each table call (``table_call``), and the tape
keeps the table and its argument; :func:`drift_with_jacobian` then writes the drift's
Jacobian by the chain rule with the tables' values and slopes as two calls each:

    d f / d a = df/da (tables held) + df/dT diag(T'(v)) dv/da.

Outside a tape ``table_call`` is the table's own call (numbers or symbols).
"""
from __future__ import annotations

from contextvars import ContextVar

import casadi as ca

_ACTIVE: ContextVar["TableTape | None"] = ContextVar("table_tape", default=None)


def table_call(table: ca.Function, argument):
    """``table(argument)``, or its tape symbol while a :class:`TableTape` records."""
    tape = _ACTIVE.get()
    return table(argument) if tape is None else tape.record(table, argument)


def slope_function(table: ca.Function) -> ca.Function:
    """The table's derivative d table / d v as a function of v (one call)."""
    v = ca.MX.sym("v")
    return ca.Function(f"{table.name()}_slope", [v], [ca.jacobian(table(v), v)], {"never_inline": True})


class TableTape:
    """The table calls of the expressions built inside ``with TableTape() as tape:``."""

    def __init__(self):
        self.tables: list[ca.Function] = []
        self.arguments: list = []           # each call's argument (SX)
        self.symbols: list = []             # the symbol standing for each call's value
        self._token = None

    def __enter__(self) -> "TableTape":
        self._token = _ACTIVE.set(self)
        return self

    def __exit__(self, *exc) -> None:
        _ACTIVE.reset(self._token)

    def record(self, table: ca.Function, argument):
        if not isinstance(argument, ca.SX) or argument.numel() != 1:
            raise TypeError("a taped table call takes one scalar SX argument")
        symbol = ca.SX.sym(f"table_{len(self.symbols)}")
        self.tables.append(table)
        self.arguments.append(argument)
        self.symbols.append(symbol)
        return symbol


def drift_with_jacobian(drift, state: ca.SX, others: list, constants: list = ()) -> ca.Function:
    """G(state, *others, *constants) -> (f, df/d(state, *others)) of ``drift(state)`` (an SX
    expression in ``state`` and the symbols ``others`` and ``constants``, the latter held
    constant: not differentiated; its table calls through ``table_call``), with each
    table's value and slope one call each. Called with SX arguments it inlines."""
    with TableTape() as tape:
        f = drift(state)
    inputs = [state, *others, *constants]
    wrt = ca.vertcat(state, *others)
    if not tape.symbols:
        return ca.Function("drift_jacobian", inputs, [f, ca.jacobian(f, wrt)])
    values, arguments = ca.vertcat(*tape.symbols), ca.vertcat(*tape.arguments)
    if ca.depends_on(arguments, values):
        raise ValueError("a table's argument depends on another table's value: not taped")
    slopes = ca.SX.sym("slope", values.numel())
    jacobian = ca.jacobian(f, wrt) + ca.mtimes(ca.jacobian(f, values),
                                               ca.mtimes(ca.diag(slopes), ca.jacobian(arguments, wrt)))
    linear = ca.Function("drift_linear", [*inputs, values, slopes], [f, jacobian])
    table_values = ca.vertcat(*[t(arguments[j]) for j, t in enumerate(tape.tables)])
    slope_of = {id(t): slope_function(t) for t in tape.tables}    # one per table, however often called
    table_slopes = ca.vertcat(*[slope_of[id(t)](arguments[j]) for j, t in enumerate(tape.tables)])
    return ca.Function("drift_jacobian", inputs, linear(*inputs, table_values, table_slopes))
