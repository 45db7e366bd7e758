"""scripts/setup is idempotent: a second run with nothing changed does no work.

Never deletes .venv or the build. The first run below brings the checkout up to
date (it may build if someone changed a build input); only later runs are judged.
"""
from __future__ import annotations

import os
import subprocess
import time
import uuid
from pathlib import Path

import pytest

from drill_core.rig_root import rig_root

ROOT = rig_root()
SETUP = ROOT / "scripts" / "setup"
STAMPS = ROOT / ".venv" / ".rig-stamps"
BUILD_LOG = ROOT / "ros_ws" / "colcon-build.log"
WORK_MARKERS = ("colcon build", "installing", "creating", "byte-compiling")   # setup did work


def run_setup(timeout: float = 600.0) -> tuple[float, str]:
    """Run scripts/setup; wall time and combined output. Fails on error or timeout."""
    t0 = time.monotonic()
    try:
        proc = subprocess.run([str(SETUP)], cwd=ROOT, capture_output=True, text=True,
                              timeout=timeout)
    except subprocess.TimeoutExpired as err:
        pytest.fail(f"scripts/setup did not finish within {timeout} s: {err.stderr!r}")
    wall = time.monotonic() - t0
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"scripts/setup failed ({proc.returncode}):\n{output[-3000:]}"
    return wall, output


def work_lines(output: str) -> list[str]:
    return [line for line in output.splitlines()
            if any(marker in line.lower() for marker in WORK_MARKERS)]


def build_fingerprint() -> tuple:
    """What a build or a dependency install would change."""
    def mtime(p: Path) -> int | None:
        return p.stat().st_mtime_ns if p.exists() else None
    return (mtime(STAMPS / "build"), mtime(STAMPS / "lock"), mtime(BUILD_LOG),
            (STAMPS / "build").read_text() if (STAMPS / "build").exists() else None)


@pytest.fixture(scope="module")
def up_to_date():
    """Bring the checkout up to date first (untimed; normally a no-op)."""
    wall, output = run_setup()
    assert "ready" in output
    print(f"\nscripts/setup (first run): {wall:.2f} s")
    return output


def test_second_run_is_fast_and_does_nothing(up_to_date):
    before = build_fingerprint()
    wall, output = run_setup(timeout=120.0)
    print(f"\nscripts/setup second run: {wall:.2f} s wall")
    assert wall < 20.0, f"second run took {wall:.2f} s"
    assert not work_lines(output), f"second run did work:\n{output}"
    assert "[setup] ready" in output
    assert build_fingerprint() == before, "second run touched the build stamps or colcon log"


def test_python_edit_needs_no_rebuild(up_to_date):
    """Python sources are symlinked into the install space: touching one, or adding a
    module, does not redo the colcon build, and the change is visible at once."""
    package = ROOT / "ros_ws" / "src" / "drill_core" / "drill_core"
    existing = package / "schema.py"
    probe_name = f"_setup_probe_{uuid.uuid4().hex[:8]}"
    probe = package / f"{probe_name}.py"
    before = build_fingerprint()
    try:
        os.utime(existing)                       # touch: new mtime, content unchanged
        probe.write_text("VALUE = 42\n", encoding="utf-8")
        wall, output = run_setup(timeout=120.0)
        print(f"\nscripts/setup after a python edit: {wall:.2f} s wall")
        assert not work_lines(output), f"setup rebuilt after a python-only change:\n{output}"
        assert wall < 20.0
        assert build_fingerprint() == before
        # the new module is importable from the built workspace without a rebuild
        env = dict(os.environ)
        check = subprocess.run(
            ["bash", "-c", f"source scripts/env.sh && python -c "
                           f"'import drill_core.{probe_name} as m; print(m.VALUE)'"],
            cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
        assert check.returncode == 0, check.stderr
        assert check.stdout.strip() == "42"
    finally:
        probe.unlink(missing_ok=True)
        for cache in package.glob(f"__pycache__/{probe_name}.*"):
            cache.unlink(missing_ok=True)


def test_virtualenv_is_byte_compiled(up_to_date):
    """Every node starts as its own process: setup compiles the venv once so no start
    compiles numpy/scipy/casadi/rclpy from source (PYTHONDONTWRITEBYTECODE may be set)."""
    check = subprocess.run(
        [str(ROOT / ".venv" / "bin" / "python"), "-c",
         "import importlib.util as u, os; "
         "spec = u.find_spec('numpy.f2py.crackfortran'); "      # a module the rig never imports
         "print(os.path.exists(u.cache_from_source(spec.origin)))"],
        capture_output=True, text=True, timeout=60)
    assert check.returncode == 0, check.stderr
    assert check.stdout.strip() == "True"
