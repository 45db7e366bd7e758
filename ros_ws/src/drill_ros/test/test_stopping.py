"""A rig process's stop signals (drill_ros.stopping): prompt while nodes are built,
only noted once they spin."""
import signal

import pytest

from drill_ros.stopping import SIGNALS, Stop


def test_a_stop_interrupts_building_and_is_only_noted_while_spinning():
    stop = Stop()
    with pytest.raises(KeyboardInterrupt):
        stop.on_signal(signal.SIGINT, None)          # building the nodes: interrupt it
    assert stop.requested
    stop = Stop()
    stop.spinning = True
    stop.on_signal(signal.SIGTERM, None)             # spinning: nothing thrown
    assert stop.requested


def test_install_takes_sigint_and_sigterm():
    before = {signum: signal.getsignal(signum) for signum in SIGNALS}
    try:
        stop = Stop().install()
        assert {signum: signal.getsignal(signum) for signum in SIGNALS} == \
            {signum: stop.on_signal for signum in SIGNALS}
    finally:
        for signum, handler in before.items():
            signal.signal(signum, handler)
