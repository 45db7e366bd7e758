"""Launch the rig graph as processes (there is no ros2 launch in our stack).

In the default layout every node runs as ``python -m <module> --ros-args -p ...``; a
process layout (drill_ros.graph.LAYOUTS) puts groups of nodes into one container
process each (drill_ros.container). Every process runs on an isolated ROS_DOMAIN_ID
with localhost discovery (the domain's dead shared-memory ports removed first,
drill_bringup.shm_ports); its output goes to ``<run>/logs/<process>.log`` and its time
budget to ``<run>/budget/<process>.json``. The recorder starts first and stops last. In fast mode
the plant starts the lockstep once every subscription the graph needs is
connected, and exits when the scenario ends (so does the estimator, once it has
estimated the last sample); the launcher then stops the rest.
A node that dies makes the launch fail with its name, exit code and last log lines.
In fast mode on a machine with two or more CPUs, the processes of the estimator and the
controller chain get one CPU to themselves and the other processes the rest
(``cpu_sets``), unless the caller runs several graphs at once (``pin_cpus`` False) or
another launch on this machine holds the pins (``PIN_LOCK``: two pinned graphs would put
both control chains on one CPU).
A split run (docs/multihost.md) launches only this host's share of the graph (``here``)
with static discovery peers; a share ends when its own finishing nodes have exited and
those on other hosts are seen gone (drill_bringup.finish_watch).
"""
from __future__ import annotations

import fcntl
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

from drill_ros import graph as graph_decl
from drill_ros import topics
from drill_ros.budget import BUDGET_DIR_ENV

from drill_bringup import shm_ports

LOG_TAIL_LINES = 15
CONSOLE_PORT = 8080
TEST_DOMAINS = range(40, 99)     # the tests' DDS domain ids (of the safe 0-101), held alike
RUN_DOMAINS = range(1, TEST_DOMAINS.start)   # the runs' own: left free by the tests
LOCK_DIR = Path(tempfile.gettempdir()) / "drill_rig_domains"
# Fast DDS writes each sample in the publishing thread instead of handing it to its
# asynchronous writer thread: no thread hand-off per message (about a fifth less CPU for a
# run, docs/speed.md); every message of the rig fits one datagram
PUBLICATION_MODE = "SYNCHRONOUS"
PIN_LOCK = "cpu-pins.lock"       # in LOCK_DIR: held by the one launch whose processes are pinned
_held_domains: dict = {}         # domain -> its open lock file: ours until released or exit


def uses_sim_time(name: str, fast: bool) -> bool:
    """Whether node ``name`` runs on /clock: in fast mode only the nodes that read their
    clock (the recorder, for its log times); the others act on, and stamp with, the
    stamps of their inputs (a clock subscription costs a callback per frame)."""
    return fast and graph_decl.BY_NAME[name].reads_clock


@dataclass
class NodeSpec:
    name: str
    module: str
    node_class: str
    params: dict = field(default_factory=dict)
    finishes: bool = False        # exits (code 0) by itself at the scenario's end

    @classmethod
    def of(cls, name: str, params: dict | None = None, finishes: bool = False) -> NodeSpec:
        """The declared node ``name`` (drill_ros.graph) with these parameters."""
        node = graph_decl.BY_NAME[name]
        return cls(name, node.module, node.node_class, dict(params or {}), finishes)


@dataclass
class ProcessSpec:
    """One process of a run: a node alone, or a container of several."""
    name: str
    nodes: list[NodeSpec]
    run_nodes: list = field(default_factory=list)    # the run's declared nodes (graph)

    @property
    def finishes(self) -> bool:
        return any(node.finishes for node in self.nodes)

    def command_line(self, marker: Path) -> list[str]:
        """Its command; a container creates ``marker`` when its finishing nodes are done."""
        if len(self.nodes) == 1:
            node = self.nodes[0]
            return [sys.executable, "-m", node.module, *ros_args(node)]
        specs = [{"module": n.module, "node_class": n.node_class, "ros_args": ros_args(n),
                  "finishes": n.finishes} for n in self.nodes]
        declared = [graph_decl.BY_NAME[n.name] for n in self.nodes]
        local = sorted(graph_decl.local_topics(declared, self.run_nodes))
        return [sys.executable, "-m", "drill_ros.container", self.name, json.dumps(specs),
                str(marker), json.dumps(local)]


def graph(scenario_controller: str, common: dict, mcap_path: Path, fast: bool,
          layout: str = "separate", kind: str = "tripping",
          extras: dict[str, dict] | None = None,
          node_params: dict[str, dict] | None = None,
          multi_stand: bool = False) -> list[NodeSpec]:
    """The node set of a run of a ``kind`` scenario (drill_ros.graph), recorder first
    and plant last; the plant waits for the lockstep's endpoints of exactly this set in
    this process layout (a container takes some topics on its local bus, not in the
    middleware). ``extras``: optional nodes (graph OPTIONAL) to add, name -> parameters;
    ``node_params``: more parameters of nodes of the set, name -> parameters;
    ``multi_stand``: the scenario trips stands (the rig floor's node)."""
    extras = extras or {}
    declared = graph_decl.run_nodes(scenario_controller, fast, kind, tuple(extras), multi_stand)
    local = graph_decl.local_subscriptions(layout, declared)
    own = {"recorder": {"output": str(mcap_path)}, "console": {"port": CONSOLE_PORT},
           **{name: {"actuator": name}
              for name in (*topics.ACTUATORS, *topics.DRILLING_ACTUATORS)}, **extras}
    for name, params in (node_params or {}).items():
        own[name] = {**own.get(name, {}), **params}
    nodes = []
    for node in declared:
        # the plant ends the run; in fast mode so does the estimator, after the last sample
        finishes = node.plant or (fast and node.name == "estimator")
        params = dict(own.get(node.name, {}))
        if node.plant:
            params["wait_for"] = graph_decl.lockstep_endpoints(declared, fast, local)
        matches = graph_decl.first_publish_matches(node, declared, local) if fast else []
        if matches:
            params["match_before_first_publish"] = matches
        nodes.append(NodeSpec.of(node.name, params, finishes))
    for node in nodes:
        node.params.update(common)
        node.params["use_sim_time"] = uses_sim_time(node.name, fast)
    return nodes


def _param_arg(key: str, value) -> str:
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, (list, tuple)):
        text = "[" + ",".join(f"'{v}'" for v in value) + "]"
    else:
        text = str(value)
    return f"{key}:={text}"


def ros_args(spec: NodeSpec) -> list[str]:
    """The node's own arguments: its name and parameters."""
    args = ["--ros-args", "-r", f"__node:={spec.name}"]
    for key, value in spec.params.items():
        args += ["-p", _param_arg(key, value)]
    return args


@dataclass
class FinishWatch:
    """The process that ends a host's share of a split run: it exits once the run's
    finishing nodes on other hosts, each seen publishing its topic of ``topics``, are gone
    (drill_bringup.finish_watch)."""
    topics: tuple[str, ...]
    name: str = "finish_watch"
    finishes: bool = True

    def command_line(self, marker: Path) -> list[str]:
        return [sys.executable, "-m", "drill_bringup.finish_watch", *self.topics]


def finish_watch(nodes: list[NodeSpec], here: set[str]) -> FinishWatch | None:
    """The watch of a split run's share ``here``: the first topic of each finishing node
    of ``nodes`` that runs elsewhere (a topic only it publishes); None if all run here."""
    elsewhere = [n.name for n in nodes if n.finishes and n.name not in here]
    if not elsewhere:
        return None
    return FinishWatch(tuple(graph_decl.BY_NAME[name].publishes[0] for name in elsewhere))


def processes(nodes: list[NodeSpec], layout: str = "separate",
              here: set[str] | None = None) -> list[ProcessSpec]:
    """The processes of ``nodes`` in ``layout`` (drill_ros.graph.LAYOUTS); with
    ``here``, those of a split run's share that runs on this host (a process of the layout
    must be wholly here or wholly elsewhere: its local bus does not cross hosts)."""
    by_name = {n.name: n for n in nodes}
    declared = [graph_decl.BY_NAME[n.name] for n in nodes]
    groups = graph_decl.process_groups(layout, declared)
    out = []
    for name, members in groups:
        names = {m.name for m in members}
        if here is not None and names & here and names - here:
            raise graph_decl.SelectionError(
                f"--layout {layout}: process {name!r} holds "
                f"{', '.join(m.name for m in members)}; --nodes takes "
                f"{', '.join(sorted(names & here))} of them: put all or none here")
        if here is None or names <= here:
            out.append(ProcessSpec(name, [by_name[m.name] for m in members], declared))
    return out


# The nodes whose processes get a CPU of their own in fast mode: the lockstep's longest
# chain per sample (estimate, solve, protection) runs there without being preempted by the
# plant's process or the recorder (Case 2, layout two: 27.4-32.8 s against 29.9-36.0 s
# wall in three interleaved pairs, docs/experiments/2026-12-01-speed.md).
CONTROL_CHAIN = frozenset({"estimator", "protection", "driller",
                           *(n.name for n in graph_decl.NODES if n.controller)})


# Fast mode only: the recorder is on no node's critical path there (its subscriptions keep
# all and it drains at the end), so it yields the CPU to the lockstep's processes (measured:
# docs/experiments/2026-12-01-speed.md). In realtime it
# keeps up with the wall clock like every node: niced under a browser's load it acknowledged
# a short-lived operator CLI's event too late to record it.
FAST_NICENESS = {"recorder": 10}


def cpu_sets(processes: list[ProcessSpec], cpus: list[int]) -> dict[str, set[int]]:
    """Process name -> the CPUs it runs on: with two or more ``cpus`` and a process of the
    control chain in the run, those processes get the first CPU, every other process the
    rest; otherwise no process is pinned (empty dict)."""
    control = {p.name for p in processes
               if any(n.name in CONTROL_CHAIN for n in getattr(p, "nodes", ()))}
    if len(cpus) < 2 or not control:
        return {}
    return {p.name: {cpus[0]} if p.name in control else set(cpus[1:]) for p in processes}


def isolated_env(domain_id: int, peers: tuple[str, ...] = ()) -> dict:
    """The processes' environment: ``domain_id``, discovery on this host only, Fast DDS
    writing synchronously (``PUBLICATION_MODE``), and with ``peers`` (a split run)
    unicast discovery of those hosts as well (ROS_STATIC_PEERS: the discovery range
    stays LOCALHOST, no multicast)."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("ROS_STATIC_PEERS", None)
    if peers:
        env["ROS_STATIC_PEERS"] = ";".join(peers)
    env["RMW_IMPLEMENTATION"] = "rmw_fastrtps_cpp"
    env["RMW_FASTRTPS_PUBLICATION_MODE"] = PUBLICATION_MODE
    env["PYTHONUNBUFFERED"] = "1"
    return env


def default_domain_id() -> int:
    """A ROS domain no other run on this machine holds, so parallel runs never see each
    other: the first free one of RUN_DOMAINS (clear of the tests' TEST_DOMAINS)."""
    return held_domain(RUN_DOMAINS)


def held_domain(domains: range) -> int:
    """A free one of ``domains`` (searched from one the process id picks), held by an flock
    on a lock file until ``release_domain`` or this process's exit: no other process of
    this machine that asks here gets it meanwhile."""
    start = os.getpid() % len(domains)
    for i in range(len(domains)):
        domain = domains[(start + i) % len(domains)]
        handle = _try_lock(f"domain-{domain}.lock")
        if handle is not None:
            _held_domains[domain] = handle
            return domain
    raise RuntimeError(f"every ROS domain in {domains[0]}..{domains[-1]} is in use "
                       f"(lock files in {LOCK_DIR})")


def _try_lock(name: str):
    """The open lock file ``name`` in LOCK_DIR with an exclusive flock on it, or None when
    another open file of this machine holds it (the lock lasts while the file is open)."""
    LOCK_DIR.mkdir(parents=True, exist_ok=True)
    handle = open(LOCK_DIR / name, "w")
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        return None
    return handle


def release_domain(domain: int) -> None:
    """Give back a domain held_domain handed this process (no-op for one it does not hold)."""
    handle = _held_domains.pop(domain, None)
    if handle is not None:
        handle.close()


def tail(path: Path, lines: int = LOG_TAIL_LINES) -> str:
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            return "".join(deque(handle, maxlen=lines))
    except OSError:
        return "(no log)"


class Launch:
    """A running graph: start, watch, stop."""

    def __init__(self, nodes: list[NodeSpec], run_dir: Path, domain_id: int,
                 layout: str = "separate", here: set[str] | None = None,
                 peers: tuple[str, ...] = (), pin_cpus: bool = True):
        names = [n.name for n in nodes]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:      # processes are tracked by name: a repeat could never be stopped
            raise ValueError(f"node names must be unique; given more than once: {', '.join(repeated)}")
        self.nodes = nodes
        self.processes = processes(nodes, layout, here)
        watch = None if here is None else finish_watch(nodes, here)
        if watch is not None:
            self.processes.append(watch)
        self.run_dir = run_dir
        self.logs = run_dir / "logs"
        self.env = isolated_env(domain_id, peers)
        self.env[BUDGET_DIR_ENV] = str(run_dir / "budget")
        self.procs: dict[str, subprocess.Popen] = {}
        fast = all(n.params.get("mode", "fast") == "fast" for n in nodes)
        self.cpus = cpu_sets(self.processes, sorted(os.sched_getaffinity(0))) \
            if pin_cpus and fast else {}
        self.niceness = dict(FAST_NICENESS) if fast else {}
        self.removed_shm_ports: list[int] = []
        self._pins = None               # the open PIN_LOCK while this launch pins

    def _take_pins(self) -> None:
        """Keep ``cpus`` only if no other launch of this machine pins its processes now."""
        if not self.cpus:
            return
        self._pins = _try_lock(PIN_LOCK)
        if self._pins is None:
            self.cpus = {}

    def start(self) -> None:
        self.logs.mkdir(parents=True, exist_ok=True)
        self.removed_shm_ports = shm_ports.remove_dead_ports(int(self.env["ROS_DOMAIN_ID"]))
        self._take_pins()
        for spec in self.processes:
            log = open(self.logs / f"{spec.name}.log", "w", encoding="utf-8")
            proc = self.procs[spec.name] = subprocess.Popen(
                spec.command_line(self.finished_marker(spec.name)), stdout=log,
                stderr=subprocess.STDOUT, env=self.env, start_new_session=True)
            log.close()
            try:                            # before its interpreter has started a thread
                if spec.name in self.cpus:
                    os.sched_setaffinity(proc.pid, self.cpus[spec.name])
                if spec.name in self.niceness:
                    os.setpriority(os.PRIO_PROCESS, proc.pid, self.niceness[spec.name])
            except ProcessLookupError:      # already gone: watch() reports its exit
                pass

    def finished_marker(self, name: str) -> Path:
        """The file a container creates once its finishing nodes have finished."""
        return self.logs / f"{name}.finished"

    def failure(self, name: str, code: int) -> str:
        return (f"node '{name}' exited with code {code}; last lines of "
                f"{self.logs / (name + '.log')}:\n{tail(self.logs / (name + '.log'))}")

    def watch(self, timeout_s: float, on_poll=None) -> tuple[bool, str]:
        """Wait for every finishing node (the plant; in fast mode the estimator too; in a
        split run's share, the watch of those on other hosts) to end the scenario; fail if
        any node dies first or time runs out."""
        finishing = {spec.name for spec in self.processes if spec.finishes}
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            finished = set()
            for name, proc in self.procs.items():
                code = proc.poll()
                if code is None:
                    if name in finishing and self.finished_marker(name).exists():
                        finished.add(name)
                    continue
                if code == 0 and name in finishing:
                    finished.add(name)
                    continue
                return False, self.failure(name, code)
            if finishing and finished == finishing:
                return True, "scenario finished"
            if on_poll is not None:
                on_poll()
            time.sleep(0.1)
        return False, f"timed out after {timeout_s:.0f} s (see {self.logs})"

    def stop(self, grace_s: float = 10.0) -> dict:
        """SIGINT every node (recorder last), escalate to SIGKILL after ``grace_s``."""
        order = [n for n in self.procs if n != "recorder"] + ["recorder"]
        for name in order:
            if name == "recorder":       # it drains what is in flight once signalled
                self._wait([n for n in order if n != "recorder"], grace_s)
            proc = self.procs.get(name)
            if proc is not None and proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        self._wait(order, grace_s)
        for proc in self.procs.values():
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        if self._pins is not None:
            self._pins.close()
            self._pins = None
        return {name: proc.returncode for name, proc in self.procs.items()}

    def _wait(self, names, grace_s: float) -> None:
        deadline = time.monotonic() + grace_s
        for name in names:
            proc = self.procs.get(name)
            if proc is None:
                continue
            try:
                proc.wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
