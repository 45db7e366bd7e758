"""The rig's ROS front door for a system ROS: every node of the graph a console_scripts
entry point of its package, installed where ``ros2 run`` looks (lib/<package>/), its
target a callable ``main``; the committed launch file the one the graph declaration
generates, and, read by parsing it (launch itself is not run here), one node per
process of each controller's realtime graph with an installed executable."""
import ast
import importlib

import pytest

from drill_bringup import launch_file
from drill_core.rig_root import rig_root
from drill_ros import graph

SRC = rig_root() / "ros_ws" / "src"
INSTALL = rig_root() / "ros_ws" / "install"


def console_scripts(package: str) -> dict[str, str]:
    """name -> 'module:function' of a package's setup.py, read by parsing it."""
    tree = ast.parse((SRC / package / "setup.py").read_text())
    for call in ast.walk(tree):
        if isinstance(call, ast.keyword) and call.arg == "entry_points":
            entries = ast.literal_eval(call.value)["console_scripts"]
            return dict((part.strip() for part in e.split("=")) for e in entries)
    return {}


@pytest.mark.parametrize("node", graph.NODES, ids=lambda n: n.name)
def test_every_node_runs_from_its_package_entry_point(node):
    package, name = launch_file.executable(node.module)
    target = console_scripts(package).get(name)
    assert target == f"{node.module}:main", (package, name, target)
    module, function = target.split(":")
    assert callable(getattr(importlib.import_module(module), function))
    assert (INSTALL / package / "lib" / package / name).is_file(), \
        f"{name} not installed under lib/{package} (setup.cfg script_dir / install_scripts)"


def test_the_committed_launch_file_is_the_generated_one():
    committed = launch_file.LAUNCH_PATH.read_text()
    assert committed == launch_file.text(), \
        "regenerate it: python -m drill_bringup.launch_file > " \
        "ros_ws/src/drill_bringup/launch/rig.launch.py"


def launched_nodes(source: str) -> list[dict]:
    """Each Node(...) of the launch file: package, executable, name and the controller
    of its condition (None: every controller)."""
    nodes = []
    for call in ast.walk(ast.parse(source)):
        if isinstance(call, ast.Call) and getattr(call.func, "id", "") == "Node":
            kw = {k.arg: k.value for k in call.keywords}
            condition = kw.get("condition")
            nodes.append({**{k: ast.literal_eval(kw[k])
                             for k in ("package", "executable", "name")},
                          "controller": ast.literal_eval(condition.args[1])
                          if condition is not None else None})
    return nodes


@pytest.mark.parametrize("controller", graph.CONTROLLERS)
def test_the_launch_file_starts_each_controllers_realtime_graph(controller):
    nodes = [n for n in launched_nodes(launch_file.LAUNCH_PATH.read_text())
             if n["controller"] in (None, controller)]
    expected = [n.name for n in graph.run_nodes(controller, fast=False)]
    assert sorted(n["name"] for n in nodes) == sorted(expected)
    for n in nodes:
        assert n["executable"] in console_scripts(n["package"]), n
