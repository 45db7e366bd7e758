"""Run a node alone in its process until shutdown; SIGINT/SIGTERM give a clean exit
(drill_ros.stopping). The process's time budget is written at the end
(drill_ros.budget)."""
from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.signals import SignalHandlerOptions

from drill_ros.budget import ProcessClock
from drill_ros.executors import SPIN_TIMEOUT_S, create_executor
from drill_ros.stopping import PROCESS


def shut_down(executor, *nodes) -> None:
    """The end of a process's ROS life: its executor shut down (None: none made), each
    node destroyed, rclpy shut down."""
    if executor is not None:
        executor.shutdown()
    for node in nodes:
        if node is not None:
            node.destroy_node()
    rclpy.try_shutdown()


def run(node_factory, args=None) -> int:
    """Create the node with ``node_factory`` and spin it; returns the process exit code."""
    stop = PROCESS.install()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node, executor = None, None
    code = 0
    clock = ProcessClock()
    try:
        node = node_factory()
        clock.spinning()
        executor = create_executor()
        executor.add_node(node)
        stop.spinning = True
        while rclpy.ok() and not stop.requested:
            executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
        code = getattr(node, "exit_code", 0)
    except (KeyboardInterrupt, ExternalShutdownException):
        code = getattr(node, "exit_code", 0) if node is not None else 0
    except Exception as err:  # a node that fails says why, then exits non-zero
        print(f"[fatal] {type(err).__name__}: {err}", file=sys.stderr, flush=True)
        code = 1
    finally:
        if node is not None:
            clock.write(node.get_name(), {node.get_name(): node.budget})
        shut_down(executor, node)
    return code
