"""Dead shared-memory ports: only a domain's ports that no live process holds, and old
enough not to be opening this moment, are removed (drill_bringup.shm_ports)."""
import fcntl
import os

from drill_bringup import shm_ports

DOMAIN = 93
OLD_S = shm_ports.SETTLE_S + 60.0


def _port(shm_dir, port, age_s, lock=None):
    """A port's files as Fast DDS leaves them, ``age_s`` old; ``lock``: its lock file's
    suffix (None: no lock file)."""
    files = [shm_dir / f"fastrtps_port{port}", shm_dir / f"sem.fastrtps_port{port}_mutex"]
    if lock:
        files.append(shm_dir / f"fastrtps_port{port}{lock}")
    for path in files:
        path.write_bytes(b"\0" * 32)
        stamp = path.stat().st_mtime - age_s
        os.utime(path, (stamp, stamp))
    return files


def test_the_domains_port_range_is_rtps_well_known():
    ports = shm_ports.domain_ports(DOMAIN)
    assert (ports.start, ports.stop) == (7400 + 250 * 93, 7400 + 250 * 94)
    assert 30661 in ports and 30911 not in ports      # 93's first participant; 94's


def test_only_dead_ports_of_the_domain_are_removed(tmp_path):
    first = shm_ports.domain_ports(DOMAIN).start
    no_lock = _port(tmp_path, first + 11, OLD_S)
    unlocked = _port(tmp_path, first + 13, OLD_S, "_el")
    held = _port(tmp_path, first + 15, OLD_S, "_sl")
    young = _port(tmp_path, first + 17, 1.0)
    other_domain = _port(tmp_path, first + 250 + 11, OLD_S)
    stranger = tmp_path / "fastrtps_0123456789abcdef"
    stranger.write_bytes(b"\0")
    with open(held[-1], "rb") as handle:                 # a live listener's lock
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert shm_ports.remove_dead_ports(DOMAIN, tmp_path) == [first + 11, first + 13]
    assert not any(p.exists() for p in no_lock + unlocked)
    assert all(p.exists() for p in held + young + other_domain + [stranger])


def test_no_shared_memory_directory_is_nothing_to_remove(tmp_path):
    assert shm_ports.remove_dead_ports(DOMAIN, tmp_path / "absent") == []
