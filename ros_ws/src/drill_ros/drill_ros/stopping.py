"""How a rig process takes a stop signal (SIGINT from the launcher, SIGTERM, Ctrl-C): it
notes the stop, and its spin loop ends at its next turn and shuts down in order (the
executor, the nodes, then the context); nothing is thrown into, or shut down under, the
Python code that happens to be running.

rclpy's own handling does both, and a process could exit with code 1 at an ordinary stop:
Python's SIGINT handler raises KeyboardInterrupt at the next bytecode the main thread
runs, which can be the constructor or a field setter of a message that rclpy's C++ take
is converting to Python (rclpy then fails the take with pybind11's RuntimeError "Unable
to convert call argument '0' to Python object"), and rclpy's handler shuts the context
down from a thread of its own, under a callback that may be about to publish (RCLError
"publisher's context is invalid"). So a rig process initialises rclpy without its signal
handlers (``rclpy.init(..., signal_handler_options=SignalHandlerOptions.NO)``, as the
recorder does) and installs ``PROCESS``: while its nodes are being built (compiling,
starting servers) a signal raises KeyboardInterrupt as Python's handler does, so a stop
is prompt then too; once they spin it is only noted.
"""
from __future__ import annotations

import signal

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Stop:
    """A process's stop signals: ``install``, then set ``spinning`` once the nodes spin."""

    def __init__(self):
        self.requested = False
        self.spinning = False

    def install(self) -> Stop:
        for signum in SIGNALS:
            signal.signal(signum, self.on_signal)
        return self

    def on_signal(self, signum, frame) -> None:
        self.requested = True
        if not self.spinning:
            raise KeyboardInterrupt


PROCESS = Stop()   # this process's: installed by the runner or the container
