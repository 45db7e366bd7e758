"""Two test hosts on this machine for the DDS tests: network namespaces joined by a veth
pair, each with its loopback up and one address in a /24 of its own. Needs root and
iproute2 (``ip``). Everything is named with a tag (the test process's pid), and
``remove`` ends every process left in the namespaces, then deletes them with the veth;
it may be called more than once."""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
from dataclasses import dataclass


def unavailable() -> str | None:
    """Why namespaces cannot be made here, or None."""
    if shutil.which("ip") is None:
        return "iproute2's ip command is not installed"
    if os.geteuid() != 0:
        return "network namespaces need root"
    return None


def ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    result = subprocess.run(["ip", *args], capture_output=True, text=True)
    if check and result.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {result.stderr.strip()}")
    return result


@dataclass
class HostPair:
    """Namespaces ``names`` joined by veth ends ``links`` with ``addresses`` (same order)."""
    names: tuple[str, str]
    links: tuple[str, str]
    addresses: tuple[str, str]

    @classmethod
    def tagged(cls, tag: int) -> HostPair:
        subnet = f"10.231.{tag % 250}"
        return cls((f"rig{tag}a", f"rig{tag}b"), (f"rv{tag}a", f"rv{tag}b"),
                   (f"{subnet}.1", f"{subnet}.2"))

    def create(self) -> None:
        ip("link", "add", self.links[0], "type", "veth", "peer", "name", self.links[1])
        for name, link, address in zip(self.names, self.links, self.addresses):
            ip("netns", "add", name)
            ip("link", "set", link, "netns", name)
            ip("-n", name, "address", "add", f"{address}/24", "dev", link)
            ip("-n", name, "link", "set", "lo", "up")
            ip("-n", name, "link", "set", link, "up")

    def command(self, index: int, argv: list[str]) -> list[str]:
        """``argv`` run inside namespace ``index``."""
        return ["ip", "netns", "exec", self.names[index], *argv]

    def packets_sent(self, index: int) -> int:
        """Packets namespace ``index`` has sent on its veth end."""
        path = f"/sys/class/net/{self.links[index]}/statistics/tx_packets"
        return int(subprocess.run(self.command(index, ["cat", path]), capture_output=True,
                                  text=True, check=True).stdout)

    def left(self) -> list[str]:
        """The namespaces and veth ends that still exist."""
        namespaces = ip("netns", "list").stdout.split()
        out = [name for name in self.names if name in namespaces]
        links = ip("-o", "link", "show").stdout
        return out + [link for link in self.links if f" {link}@" in links or f" {link}:" in links]

    def remove(self) -> None:
        namespaces = ip("netns", "list").stdout.split()
        for name in self.names:
            if name not in namespaces:
                continue
            for pid in ip("netns", "pids", name).stdout.split():
                try:
                    os.kill(int(pid), signal.SIGKILL)
                except ProcessLookupError:
                    pass
            ip("netns", "del", name)
        for link in self.links:          # still in this namespace if create stopped early
            if ip("link", "show", link, check=False).returncode == 0:
                ip("link", "del", link)
