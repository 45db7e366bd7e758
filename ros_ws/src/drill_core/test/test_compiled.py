"""The compile path: compiled functions agree with CasADi's VM, are cached, and fail clearly."""
import casadi as ca
import numpy as np
import pytest

from drill_core.compiled import CompileError, compile_library, compiled


def _step_with_jacobian():
    x = ca.SX.sym("x", 3)
    u = ca.SX.sym("u")
    xn = ca.vertcat(x[1], -ca.sin(x[0]) + u * ca.tanh(x[2]), ca.sqrt(x[0] ** 2 + 1.0) * x[1])
    out = ca.SX.sym("out", 3)
    jac = ca.Function("jac_step", [x, u, out], [ca.jacobian(xn, x), ca.jacobian(xn, u)],
                      ["x", "u", "out_x_next"], ["jac_x_next_x", "jac_x_next_u"])
    return ca.Function("step", [x, u], [xn], ["x", "u"], ["x_next"], {"custom_jacobian": jac})


def test_compiled_function_and_its_jacobian_match_the_vm_bit_for_bit(tmp_path):
    step = _step_with_jacobian()
    fast = compiled([step, step.jacobian()], "test_step", tmp_path)["step"]
    x = np.array([0.3, -1.2, 0.7])
    assert np.array_equal(np.array(fast(x, 0.4)), np.array(step(x, 0.4)))
    # the library's jac_step is the derivative CasADi uses for the external
    xs, us = ca.MX.sym("x", 3), ca.MX.sym("u")
    jac_fast = ca.Function("j", [xs, us], [ca.jacobian(fast(xs, us), xs)])
    jac_vm = ca.Function("j", [xs, us], [ca.jacobian(step(xs, us), xs)])
    assert np.array_equal(np.array(jac_fast(x, 0.4)), np.array(jac_vm(x, 0.4)))


def test_a_configuration_is_compiled_once(tmp_path):
    step = _step_with_jacobian()
    first = compile_library([step], "test_once", tmp_path)
    stamp = first.stat().st_mtime_ns
    assert compile_library([step], "test_once", tmp_path) == first
    assert first.stat().st_mtime_ns == stamp
    assert [p.name for p in tmp_path.iterdir()] == [first.name]      # no temporaries left


def test_a_missing_compiler_is_named(tmp_path, monkeypatch):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    with pytest.raises(CompileError, match="no-such-cc.*not found"):
        compile_library([_step_with_jacobian()], "test_missing", tmp_path)
