"""The options of a run split across hosts (``rig run --nodes --domain --peers``,
docs/multihost.md), checked before anything is launched."""
from __future__ import annotations

import ipaddress
import re

from drill_ros.graph import SelectionError

DOMAIN_IDS = range(0, 102)       # the ROS domain ids whose DDS ports are valid on any host
_HOST_NAME = re.compile(r"[A-Za-z0-9]([A-Za-z0-9-]*[A-Za-z0-9])?(\.[A-Za-z0-9]([A-Za-z0-9-]*[A-Za-z0-9])?)*")


def peer_problem(text: str) -> str | None:
    """Why ``text`` cannot be a discovery peer, or None: an IPv4 address or a DNS host name
    is one (rmw_fastrtps resolves a peer to its first IPv4 address, so an IPv6 one is not)."""
    try:
        address = ipaddress.ip_address(text)
    except ValueError:
        return None if _HOST_NAME.fullmatch(text) else "is not an IP address or host name"
    return None if address.version == 4 else "is IPv6: Fast DDS takes IPv4 peers only"


def split_options(nodes: str | None, domain: int | None, peers: str | None) -> tuple[str, ...]:
    """Check ``--nodes``/``--domain``/``--peers`` together; the peers, one address each.
    A share of a split run needs the domain every host agrees on (the default picks a free
    one on each host, which need not match)."""
    if domain is not None and domain not in DOMAIN_IDS:
        raise SelectionError(f"--domain {domain}: a ROS domain id is "
                             f"{DOMAIN_IDS[0]}..{DOMAIN_IDS[-1]}")
    if nodes is not None and domain is None:
        raise SelectionError("--nodes needs --domain N, the same on every host of the run")
    out = tuple(p.strip() for p in (peers or "").split(",") if p.strip())
    for peer in out:
        problem = peer_problem(peer)
        if problem:
            raise SelectionError(f"--peers: {peer!r} {problem}")
    if peers is not None and not out:
        raise SelectionError(f"--peers {peers!r}: no address given")
    return out
