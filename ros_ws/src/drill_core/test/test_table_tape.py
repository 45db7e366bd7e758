"""The taped table calls: the drift's Jacobian by the chain rule over each table's value
and slope equals CasADi's automatic differentiation of the same expression, with each
table called twice instead of once per seed direction."""
import casadi as ca
import numpy as np
import pytest

from drill_core.table_tape import TableTape, drift_with_jacobian, table_call

GRID = np.linspace(-2.0, 2.0, 81)
SINE = ca.interpolant("sine", "bspline", [GRID], np.sin(GRID))
CUBE = ca.interpolant("cube", "bspline", [GRID], GRID ** 3)


def calls(fn: ca.Function) -> int:
    return sum(fn.instruction_id(k) == ca.OP_CALL for k in range(fn.n_instructions()))


def drift(x, p):
    return ca.vertcat(x[1] * table_call(SINE, 0.3 * x[0] - p[0]),
                      table_call(CUBE, x[0] + x[1]) - p[1] * table_call(SINE, x[1]),
                      x[2] * p[0] * table_call(CUBE, 0.5 * x[2]))


def test_the_chain_rule_jacobian_is_automatic_differentiations():
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 2)
    expected = ca.Function("expected", [x, p], [drift(x, p), ca.jacobian(drift(x, p), ca.vertcat(x, p))])
    ours = drift_with_jacobian(lambda s: drift(s, p), x, [p])
    rng = np.random.default_rng(3)
    for _ in range(5):
        args = [rng.uniform(-1.0, 1.0, 3), rng.uniform(-1.0, 1.0, 2)]
        (f_ours, j_ours), (f_exp, j_exp) = ours(*args), expected(*args)
        assert np.array_equal(np.asarray(f_ours), np.asarray(f_exp))
        assert np.allclose(np.asarray(j_ours), np.asarray(j_exp), rtol=1e-13, atol=1e-14)
    assert calls(ours) == 2 * 4                     # four table calls: a value and a slope each
    assert calls(expected) > calls(ours)


def test_outside_a_tape_a_table_call_is_the_tables_own():
    assert float(table_call(SINE, 0.5)) == float(SINE(0.5))
    v = ca.SX.sym("v")
    assert calls(ca.Function("f", [v], [table_call(SINE, v)])) == 1


def test_a_table_argument_that_depends_on_a_table_is_refused():
    x = ca.SX.sym("x", 1)
    with pytest.raises(ValueError, match="depends on another table"):
        drift_with_jacobian(lambda s: table_call(SINE, table_call(CUBE, s[0])), x, [])


def test_a_tape_records_only_inside_its_block():
    v = ca.SX.sym("v")
    with TableTape() as tape:
        inside = table_call(SINE, v)
    outside = table_call(SINE, v)
    assert len(tape.symbols) == 1 and inside.is_symbolic() and not outside.is_symbolic()
