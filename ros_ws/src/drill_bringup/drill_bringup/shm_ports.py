"""Dead shared-memory ports of a ROS domain, removed before a run starts in it.

Fast DDS (the rig's middleware, on this host) delivers between processes through a
shared-memory segment per listening port, ``/dev/shm/fastrtps_port<N>``, beside it a lock
file ``..._el`` (or ``..._sl``) that its listening process holds locked while alive and a
mutex ``sem.fastrtps_port<N>_mutex``. A process killed at the wrong moment can leave the
segment behind without a held lock. A later participant of the same domain that gets
that port number takes the stale segment over and samples pushed to it are never read:
the next run in that domain stalls at its first frame (measured: every run of a domain
holding such ports stalled at t = 0; with them removed, none did). Fast DDS's own
cleaner (``fastdds shm clean``) only looks at ports that still have a lock file.

A port of the domain (DDSI-RTPS's well-known ports: ``PORT_BASE + DOMAIN_GAIN * domain``
and the ``DOMAIN_GAIN`` above it) is dead when none of its lock files is locked and its
segment is older than ``SETTLE_S`` (a port created this moment by a participant
starting elsewhere in the domain has no lock yet)."""
from __future__ import annotations

import fcntl
import os
import re
import time
from pathlib import Path

SHM_DIR = Path("/dev/shm")
PORT_BASE = 7400          # DDSI-RTPS 9.6.1.1: PB
DOMAIN_GAIN = 250         # DDSI-RTPS 9.6.1.1: DG, the ports of one domain
SETTLE_S = 30.0           # s: a younger segment may belong to a participant still opening it
LOCK_SUFFIXES = ("_el", "_sl")
PORT_FILE = re.compile(r"^fastrtps_port(\d{1,5})$")


def domain_ports(domain_id: int) -> range:
    """The UDP/shared-memory port numbers of ``domain_id``."""
    first = PORT_BASE + DOMAIN_GAIN * domain_id
    return range(first, first + DOMAIN_GAIN)


def _locked(path: Path) -> bool:
    """Whether a live process holds ``path`` locked (flock, as Fast DDS's lock files)."""
    try:
        with open(path, "rb") as handle:       # never creates it
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return False
    except FileNotFoundError:
        return False
    except OSError:
        return True


def port_files(port: int, shm_dir: Path = SHM_DIR) -> list[Path]:
    """A port's segment, its lock files and its mutex."""
    name = f"fastrtps_port{port}"
    return [shm_dir / name, *(shm_dir / f"{name}{s}" for s in LOCK_SUFFIXES),
            shm_dir / f"sem.{name}_mutex"]


def dead_ports(domain_id: int, shm_dir: Path = SHM_DIR) -> list[int]:
    """The ports of ``domain_id`` in ``shm_dir`` that no live process listens on."""
    ports = domain_ports(domain_id)
    now = time.time()
    try:
        names = os.listdir(shm_dir)
    except FileNotFoundError:       # no POSIX shared memory here: nothing to clean
        return []
    dead = []
    for name in names:
        match = PORT_FILE.match(name)
        if not match or int(match.group(1)) not in ports:
            continue
        port = int(match.group(1))
        segment, *locks, _ = port_files(port, shm_dir)
        try:
            age_s = now - segment.stat().st_mtime
        except FileNotFoundError:   # removed by its owner meanwhile
            continue
        if age_s >= SETTLE_S and not any(_locked(lock) for lock in locks):
            dead.append(port)
    return sorted(dead)


def remove_dead_ports(domain_id: int, shm_dir: Path = SHM_DIR) -> list[int]:
    """Remove the dead ports of ``domain_id`` (dead_ports); returns their numbers."""
    dead = dead_ports(domain_id, shm_dir)
    for port in dead:
        for path in port_files(port, shm_dir):
            path.unlink(missing_ok=True)
    return dead
