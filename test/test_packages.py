"""The workspace's packages: every import of another package declared in package.xml,
dependencies pointing one way (no cycle between packages or between modules), and the
plain-Python core free of ROS."""
import ast
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from drill_core.rig_root import rig_root

SRC = rig_root() / "ros_ws" / "src"
PACKAGES = sorted(p.parent.name for p in SRC.glob("*/package.xml"))
ROS_RUNTIME = {"rclpy", "rosidl_runtime_py", "builtin_interfaces", "std_msgs", "drill_msgs"}


def imported_top_modules(package: str) -> dict[str, str]:
    """Top-level module -> first file importing it, over the package's own code (not tests)."""
    found: dict[str, str] = {}
    for path in sorted((SRC / package / package).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                found.setdefault(name.split(".")[0], str(path.relative_to(SRC)))
    return found


def declared_dependencies(package: str) -> set[str]:
    root = ET.parse(SRC / package / "package.xml").getroot()
    return {e.text.strip() for tag in ("depend", "exec_depend") for e in root.iter(tag)}


def workspace_imports(package: str) -> dict[str, str]:
    """The other workspace packages ``package``'s code imports -> an importing file."""
    return {m: f for m, f in imported_top_modules(package).items()
            if m in PACKAGES and m != package}


PYTHON_PACKAGES = [p for p in PACKAGES if (SRC / p / p).is_dir()]


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_every_imported_package_is_declared(package):
    declared = declared_dependencies(package)
    used = {**workspace_imports(package),
            **{m: f for m, f in imported_top_modules(package).items() if m == "rclpy"}}
    missing = {m: f for m, f in used.items() if m not in declared}
    assert not missing, f"{package}/package.xml does not declare what its code imports: {missing}"


def test_package_dependencies_have_no_cycle():
    edges = {p: set(workspace_imports(p)) for p in PYTHON_PACKAGES}
    state: dict[str, str] = {}

    def visit(p, path):
        if state.get(p) == "done":
            return
        assert state.get(p) != "open", "import cycle: " + " -> ".join(path + [p])
        state[p] = "open"
        for q in sorted(edges.get(p, ())):
            visit(q, path + [p])
        state[p] = "done"

    for p in PYTHON_PACKAGES:
        visit(p, [])


def module_imports() -> dict[str, set[str]]:
    """Every workspace module -> the workspace modules it imports (at any depth of its code,
    a late or type-only import included)."""
    files = {}
    for package in PYTHON_PACKAGES:
        for path in (SRC / package / package).rglob("*.py"):
            parts = path.relative_to(SRC / package).with_suffix("").parts
            files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    edges = {}
    for name, path in files.items():
        out = set()
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                out |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                out |= {node.module} | {f"{node.module}.{a.name}" for a in node.names}
        edges[name] = {m for m in out if m in files and m != name and not name.startswith(m + ".")
                       and "." in m}
    return edges


def test_modules_import_in_no_cycle():
    edges = module_imports()
    state: dict[str, str] = {}

    def visit(m, path):
        if state.get(m) == "done":
            return
        assert state.get(m) != "open", "module import cycle: " + " -> ".join(path + [m])
        state[m] = "open"
        for n in sorted(edges[m]):
            visit(n, path + [m])
        state[m] = "done"

    for m in sorted(edges):
        visit(m, [])


def test_core_imports_no_ros():
    ros = {m: f for m, f in imported_top_modules("drill_core").items()
           if m in ROS_RUNTIME or m in PACKAGES and m != "drill_core"}
    assert not ros, f"drill_core is plain Python, yet imports {ros}"
    assert "rclpy" not in declared_dependencies("drill_core")


def test_the_analysis_reads_recordings_without_ros():
    import subprocess
    import sys
    ros = {m: f for m, f in imported_top_modules("drill_analysis").items() if m in ROS_RUNTIME}
    assert not ros, f"drill_analysis is plain Python over recordings, yet imports {ros}"
    code = "import sys, drill_analysis.report; print('rclpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False", "importing the report pulls in rclpy"


def test_an_undeclared_import_is_found(tmp_path, monkeypatch):
    """The check reads imports inside functions too (a late import is still a dependency)."""
    pkg = tmp_path / "drill_a" / "drill_a"
    pkg.mkdir(parents=True)
    (pkg / "m.py").write_text("def f():\n    from drill_b.x import y\n    return y\n")
    (tmp_path / "drill_a" / "package.xml").write_text("<package><name>drill_a</name></package>")
    (tmp_path / "drill_b" / "drill_b").mkdir(parents=True)
    (tmp_path / "drill_b" / "package.xml").write_text("<package><name>drill_b</name></package>")
    monkeypatch.setitem(globals(), "SRC", tmp_path)
    monkeypatch.setitem(globals(), "PACKAGES", ["drill_a", "drill_b"])
    assert workspace_imports("drill_a") == {"drill_b": str(Path("drill_a/drill_a/m.py"))}
    assert declared_dependencies("drill_a") == set()
