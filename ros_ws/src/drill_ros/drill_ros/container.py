"""Several of the rig's nodes in one process under one executor, as a ROS 2 component
container holds components (rclpy has no container of its own).

Run: python -m drill_ros.container <process name> <JSON list of nodes> <marker>
<JSON list of local topics>, each node {"module", "node_class", "ros_args" (the node's own
--ros-args: name remap and parameters), "finishes"}. The nodes are the same classes that run alone; they take their
arguments per node (no global arguments), so two nodes of one class (the actuators)
keep their own names and parameters. The local topics (drill_ros.graph.local_topics)
go between the nodes here on the local bus (drill_ros.local_bus), not through the
middleware; the loop delivers its queue between spins of the executor.

When every node here that finishes a run has finished (RigNode.finish) the container
creates the file <marker> and goes on spinning, so the other nodes here still act on
what is in flight (the NMPC's last command after the estimator's last estimate), until
the launcher stops it (SIGINT/SIGTERM: drill_ros.stopping), as it stops a process
of one node. A node that finishes with a non-zero exit code (a stalled lockstep, a
diverged plant) ends the process at once with that code.
"""
from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.signals import SignalHandlerOptions

from drill_ros.budget import ProcessClock
from drill_ros.executors import SPIN_TIMEOUT_S, create_executor
from drill_ros.local_bus import LocalBus
from drill_ros.node import CONTAINED
from drill_ros.runner import shut_down
from drill_ros.stopping import PROCESS


def create_nodes(specs: list[dict]) -> list:
    """The nodes of ``specs``, each with its own arguments."""
    nodes = []
    for spec in specs:
        cls = getattr(importlib.import_module(spec["module"]), spec["node_class"])
        nodes.append(cls(cli_args=list(spec["ros_args"]), use_global_arguments=False))
    return nodes


def spin(executor, bus: LocalBus, nodes, finishing, marker: Path) -> None:
    """Spin until stopped or a node fails; mark the finish of the finishing nodes."""
    marked = False
    PROCESS.spinning = True
    while rclpy.ok() and not PROCESS.requested:
        bus.deliver()
        executor.spin_once(timeout_sec=0.0 if bus.pending else SPIN_TIMEOUT_S)
        if any(getattr(node, "exit_code", 0) for node in nodes):
            return
        if not marked and finishing and all(node.finished for node in finishing):
            marker.touch()
            marked = True


def main(argv: list[str]) -> int:
    process, specs, marker = argv[1], json.loads(argv[2]), Path(argv[3])
    bus = LocalBus(json.loads(argv[4]))
    CONTAINED.update(active=True, bus=bus)
    PROCESS.install()
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    nodes, code = [], 0
    executor = create_executor()
    clock = ProcessClock()
    try:
        nodes = create_nodes(specs)
        for node in nodes:
            executor.add_node(node)
        finishing = [node for node, spec in zip(nodes, specs) if spec["finishes"]]
        clock.spinning()
        spin(executor, bus, nodes, finishing, marker)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as err:  # a node that fails says why, then the process exits non-zero
        print(f"[fatal] {type(err).__name__}: {err}", file=sys.stderr, flush=True)
        code = 1
    finally:
        clock.write(process, {node.get_name(): node.budget for node in nodes})
        code = code or next((c for c in (getattr(n, "exit_code", 0) for n in nodes) if c), 0)
        shut_down(executor, *nodes)
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv))
