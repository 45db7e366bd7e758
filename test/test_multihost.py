"""A run split across two hosts (docs/multihost.md), over DDS between two network
namespaces joined by a veth pair that the test makes and removes: the plant, the actuators
and the recorder on one, the estimator, the NMPC and the protection on the other, each
share started with ``rig run --nodes --domain --peers``. The short trip must complete on
both, over the veth, and record the same data as the same scenario and seed on one host
(run in the first namespace too, so no other run on this machine can reach either).
"""
import os
import subprocess
import sys

import pytest
from net_namespaces import HostPair, unavailable
from rig_testing import assert_same_recorded_data, held_test_domain, wait_for

from drill_bag import mcap_io

from drill_rig import cli
from drill_ros import topics

pytestmark = [pytest.mark.dds, pytest.mark.slow,
              pytest.mark.skipif(unavailable() is not None, reason=str(unavailable()))]
SCENARIO = cli.ROOT / "test" / "scenarios" / "sweep_short.yaml"     # 20 s
CONTROLLER, SEED = "nmpc", 3
SPLIT_DOMAIN, ONE_HOST_DOMAIN = held_test_domain(), held_test_domain()
SHARES = ("plant,actuators,recorder", "estimator,nmpc,protection")
RUN_TIMEOUT_S = 600.0


@pytest.fixture
def hosts():
    pair = HostPair.tagged(os.getpid())
    try:
        pair.create()
        yield pair
    finally:
        pair.remove()


def _rig_run(hosts: HostPair, index: int, runs_dir, log, *flags: str) -> subprocess.Popen:
    """``rig run`` of the scenario in namespace ``index``."""
    argv = [sys.executable, "-m", "drill_rig.cli", "run", str(SCENARIO),
            "--controller", CONTROLLER, "--seed", str(SEED), "--runs-dir", str(runs_dir), *flags]
    return subprocess.Popen(hosts.command(index, argv), cwd=cli.ROOT, stdout=log,
                            stderr=subprocess.STDOUT, env=dict(os.environ, RIG_ROOT=str(cli.ROOT)))


def _wait(processes, what: str, logs) -> None:
    try:
        wait_for(lambda: all(p.poll() is not None for p in processes), RUN_TIMEOUT_S, what)
    finally:
        for log in logs:
            log.close()


def test_split_run_completes_over_the_veth_and_records_what_one_host_does(hosts, tmp_path):
    runs = [tmp_path / "plant_host", tmp_path / "control_host"]
    logs = [open(tmp_path / f"share{i}.log", "w") for i in range(2)]
    shares = [_rig_run(hosts, i, runs[i], logs[i], "--domain", str(SPLIT_DOMAIN),
                       "--nodes", SHARES[i], "--peers", hosts.addresses[1 - i])
              for i in range(2)]
    _wait(shares, "both shares of the split run to exit", logs)
    output = [(tmp_path / f"share{i}.log").read_text() for i in range(2)]
    assert [p.returncode for p in shares] == [0, 0], output
    sent = [hosts.packets_sent(i) for i in range(2)]

    split = next(runs[0].glob("*/*.mcap"))
    assert list(runs[1].glob("*/*.mcap")) == []           # the recorder ran on the plant's host
    assert (split.parent / "summary.json").exists()
    measurements = mcap_io.topics(split)[topics.MEASUREMENT].message_count
    assert measurements == 201                            # t = 0 .. 20 s at 10 Hz
    # the shares talked over the veth, not through this machine's shared memory: every
    # measurement went to the estimator, and every estimate to the recorder, as packets
    assert min(sent) > measurements, sent

    log = open(tmp_path / "one_host.log", "w")
    one_host = _rig_run(hosts, 0, tmp_path / "one_host", log, "--domain", str(ONE_HOST_DOMAIN))
    _wait([one_host], "the one-host run to exit", [log])
    assert one_host.returncode == 0, (tmp_path / "one_host.log").read_text()
    compared = assert_same_recorded_data(split, next((tmp_path / "one_host").glob("*/*.mcap")))
    assert compared == 3 * 201 + 2 * 21                   # truth, measurement, estimate; commands

    hosts.remove()
    assert hosts.left() == []
