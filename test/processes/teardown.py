"""A deadline on a test helper's ROS teardown.

rclpy's teardown over Fast DDS (executor, node, context) has, once in many fresh-clone
runs, not returned for over a minute after the helper had printed its result. The rig's
own processes meet the same with the launcher's SIGINT-then-SIGKILL grace; a helper meets
it with this watchdog, which writes every thread's stack to stderr (to show where it was
stuck) and ends the process. The test reads the helper's result from the ``EXIT <code>``
line printed before the teardown.
"""
from __future__ import annotations

import faulthandler

TEARDOWN_S = 15.0          # a teardown takes well under a second alone and ~10 s under load
STUCK_MARK = "Timeout ("   # how faulthandler's dump begins


def arm_watchdog(seconds: float = TEARDOWN_S) -> None:
    """From now on, past ``seconds`` the stacks go to stderr and the process exits (code 1).
    Armed before the teardown and never cancelled, so a stall in the interpreter's own
    finalisation (where the DDS participant goes) is caught too."""
    faulthandler.dump_traceback_later(seconds, exit=True)
