"""The rig's node graph, declared once: every topic (type, QoS) and every node (module,
what it publishes and subscribes, which kinds of scenario it runs in).

A tripping scenario runs the well-control graph (plant, four actuators, estimator, an
advisor, protection); a drilling scenario (drill_string) its own: the driller, the top
drive and the block feed, and the drill-string plant. The launcher picks a run's nodes
from ``NODES`` and derives from them the endpoints the plant waits for before the
lockstep starts (``lockstep_endpoints``);
docs/architecture.md's topic table is generated from it (``python -m
drill_ros.graph``) and a test holds the two together. The nodes create their
endpoints in code; this table is what they must match (docs/design.md §2).
"""
from __future__ import annotations

import sys
from dataclasses import dataclass

from rclpy.qos import DurabilityPolicy, HistoryPolicy

from drill_ros import topics
from drill_core.scenario import SCENARIO_KINDS

CLOCK = "/clock"
EVERY_TOPIC = "*"                 # the recorder subscribes to whatever is published
FRAMES = tuple(topics.actuator_frame(name) for name in topics.ACTUATORS)
DRILLING_FRAMES = tuple(topics.actuator_frame(name) for name in topics.DRILLING_ACTUATORS)


QOS_PROFILES = {"reliable": topics.RELIABLE, "latched": topics.LATCHED,   # a topic's QoS kind
                "event log": topics.EVENT_LOG}                          # -> its profile
LOSSLESS = ("reliable", "event log")    # every sample reaches every reader


def describe_qos(profile) -> str:
    """A QoS profile in the words of docs/architecture.md's topic table."""
    durability = "transient local, " if profile.durability == DurabilityPolicy.TRANSIENT_LOCAL \
        else ""
    history = "keep all" if profile.history == HistoryPolicy.KEEP_ALL else f"depth {profile.depth}"
    return f"{profile.reliability.name.lower().replace('_', ' ')}, {durability}{history}"


@dataclass(frozen=True)
class Topic:
    name: str
    type: str          # package/Type
    qos: str           # a key of QOS_PROFILES
    note: str = ""


TOPICS = (
    Topic(topics.MEASUREMENT, "drill_msgs/RigMeasurement", "reliable"),
    Topic(topics.TRUTH, "drill_msgs/PlantTruth", "reliable", "evaluation only"),
    Topic(topics.RIG_EVENTS, "drill_msgs/OperatorEvent", "event log",
          "scenario events (faults, formation): evaluation and console only"),
    Topic(topics.FLOOR, "drill_msgs/RigFloor", "reliable", "a multi-stand trip only"),
    *(Topic(frame, "drill_msgs/ActuatorFrame", "reliable") for frame in FRAMES),
    Topic(topics.COMMAND, "drill_msgs/RigCommand", "reliable", "advisor's command"),
    Topic(topics.MACHINE_COMMAND, "drill_msgs/RigCommand", "reliable",
          "after process protection"),
    Topic(topics.ESTIMATE, "drill_msgs/StateEstimate", "reliable"),
    Topic(topics.NMPC_STATUS, "drill_msgs/NmpcStatus", "reliable"),
    Topic(topics.SETPOINTS, "drill_msgs/Setpoints", "latched"),
    Topic(topics.OPERATOR_EVENTS, "drill_msgs/OperatorEvent", "event log"),
    Topic(topics.PROTECTION_EVENTS, "drill_msgs/OperatorEvent", "event log", "clamps and alarms"),
    Topic(topics.AUTOMATION_LEVEL, "std_msgs/String", "latched",
          "operator's request: manual, advisory or closed_loop"),
    Topic(topics.EMERGENCY_STOP, "std_msgs/Bool", "latched", "operator's request"),
    Topic(topics.LEVEL_IN_FORCE, "std_msgs/String", "latched", "the level applied"),
    Topic(topics.ESTOP_IN_FORCE, "std_msgs/Bool", "latched", "the stop applied"),
    Topic(topics.DIAGNOSTICS, "diagnostic_msgs/DiagnosticArray", "reliable",
          "each node's NodeStatus in the ROS form, once a second"),
    Topic(CLOCK, "rosgraph_msgs/Clock", "reliable", "fast mode only"),
    Topic(topics.SURFACE, "drill_msgs/SurfaceMeasurement", "reliable", "drilling mode"),
    Topic(topics.DOWNHOLE, "drill_msgs/DownholeMeasurement", "reliable",
          "drilling mode, wired pipe"),
    Topic(topics.DRILLING_TRUTH, "drill_msgs/DrillingTruth", "reliable",
          "drilling mode, evaluation only"),
    Topic(topics.DRILLING_COMMAND, "drill_msgs/DrillingCommand", "reliable", "drilling mode"),
    *(Topic(frame, "drill_msgs/ActuatorFrame", "reliable", "drilling mode")
      for frame in DRILLING_FRAMES),
)
BY_TOPIC = {t.name: t for t in TOPICS}


def latched(topic: str) -> bool:
    """Whether ``topic`` is declared latched (a late reader still gets its last value);
    every other topic, a node's status topic included, loses no sample (LOSSLESS)."""
    declared = BY_TOPIC.get(topic)
    return declared is not None and declared.qos == "latched"


@dataclass(frozen=True)
class Node:
    name: str
    module: str
    node_class: str                  # the rclpy node class in ``module`` (composition)
    publishes: tuple[str, ...]
    subscribes: tuple[str, ...]
    controller: str | None = None    # the scenario controller this advisor is
    reads_clock: bool = False        # runs on /clock in fast mode (the others act on stamps)
    realtime_only: bool = False
    kinds: tuple[str, ...] = ("tripping",)   # the scenario kinds whose runs hold it
    plant: bool = False              # the run's clock: starts the lockstep once the graph is
                                     # connected (wait_for) and ends the run
    optional: bool = False           # in a run only when asked for (run_nodes' ``extras``)
    multi_stand: bool = False        # in a run only when its scenario trips stands (``trip:``)
    truth_side: bool = False         # given the plant's mismatch (drill_core.mismatch): the
                                     # plant, the actuators and the recorder, never an advisor,
                                     # the estimator or the protection

    @property
    def status_topic(self) -> str:
        return topics.NMPC_NODE_STATUS if self.name == "nmpc" else topics.status(self.name)

    def subscribes_to(self, topic: str) -> bool:
        return topic in self.subscribes or EVERY_TOPIC in self.subscribes


FLOOR_ACTUATORS = ("drawworks", "mud_pump")   # the actuators the rig floor drives


def _actuator(name: str) -> Node:
    floor = (topics.FLOOR,) if name in FLOOR_ACTUATORS else ()
    return Node(name, "drill_plant.actuator_node", "ActuatorNode", (topics.actuator_frame(name),),
                (topics.MEASUREMENT, topics.MACHINE_COMMAND, *floor), truth_side=True)


def _drilling_actuator(name: str) -> Node:
    return Node(name, "drill_string.ros.actuator_node", "DrillingActuatorNode",
                (topics.actuator_frame(name),), (topics.SURFACE, topics.DRILLING_COMMAND),
                kinds=("drilling",))


NODES = (
    Node("recorder", "drill_bag.recorder", "Recorder", (), (EVERY_TOPIC,), reads_clock=True,
         kinds=SCENARIO_KINDS, truth_side=True),
    *(_actuator(name) for name in topics.ACTUATORS),
    Node("rig_floor", "drill_plant.floor_node", "FloorNode", (topics.FLOOR,),
         (topics.MEASUREMENT, topics.actuator_frame("drawworks")), multi_stand=True),
    Node("estimator", "drill_estimator.estimator_node", "EstimatorNode", (topics.ESTIMATE,),
         (topics.MEASUREMENT, *FRAMES, topics.FLOOR)),
    Node("nmpc", "drill_nmpc.nmpc_node", "NmpcNode",
         (topics.COMMAND, topics.NMPC_STATUS, topics.SETPOINTS, topics.OPERATOR_EVENTS),
         (topics.ESTIMATE, *(topics.actuator_frame(n) for n in ("drawworks", "bpp", "mud_pump")),
          topics.MACHINE_COMMAND, topics.FLOOR),
         controller="nmpc"),
    Node("automated_mpd", "drill_nmpc.automated_mpd_node", "AutomatedMpdNode",
         (topics.COMMAND, topics.SETPOINTS, topics.OPERATOR_EVENTS),
         (topics.ESTIMATE, topics.MACHINE_COMMAND, topics.FLOOR), controller="automated_mpd"),
    Node("baseline", "drill_nmpc.baseline_node", "BaselineNode",
         (topics.COMMAND, topics.SETPOINTS, topics.OPERATOR_EVENTS),
         (topics.MEASUREMENT, topics.MACHINE_COMMAND, topics.FLOOR), controller="baseline"),
    Node("sequencer", "drill_nmpc.sequencer_node", "SequencerNode", (topics.COMMAND,), (topics.MEASUREMENT,),
         controller="open_loop"),
    Node("protection", "drill_protection.protection_node", "ProtectionNode",
         (topics.MACHINE_COMMAND, topics.PROTECTION_EVENTS, topics.LEVEL_IN_FORCE,
          topics.ESTOP_IN_FORCE),
         (topics.COMMAND, topics.MEASUREMENT,
          *(topics.actuator_frame(n) for n in topics.WATCHED_ACTUATORS), topics.SETPOINTS,
          topics.EMERGENCY_STOP, topics.AUTOMATION_LEVEL, topics.FLOOR)),
    Node("console", "drill_hmi.console", "ConsoleNode",
         (topics.OPERATOR_EVENTS, topics.AUTOMATION_LEVEL, topics.EMERGENCY_STOP),
         (topics.MEASUREMENT, topics.TRUTH, topics.ESTIMATE, topics.NMPC_STATUS, topics.SETPOINTS,
          topics.OPERATOR_EVENTS, topics.PROTECTION_EVENTS, topics.AUTOMATION_LEVEL,
          topics.EMERGENCY_STOP, topics.LEVEL_IN_FORCE, topics.ESTOP_IN_FORCE, topics.RIG_EVENTS,
          topics.DIAGNOSTICS, topics.FLOOR, *FRAMES),
         realtime_only=True),
    # Optional observers (``rig run --foxglove`` / ``--opcua`` / ``--wits0``; drill_gateway): their
    # subscriptions are best-effort keep-last (latched topics: depth 1), so they never hold
    # up a writer; the plant waits for them at the start like for every other reader.
    Node("foxglove_bridge", "drill_gateway.foxglove_node", "FoxgloveBridgeNode", (),
         (EVERY_TOPIC,), kinds=SCENARIO_KINDS, optional=True),
    Node("opcua_gateway", "drill_gateway.opcua_node", "OpcuaGatewayNode",
         (topics.OPERATOR_EVENTS, topics.AUTOMATION_LEVEL),
         (topics.MEASUREMENT, topics.ESTIMATE, topics.SETPOINTS, topics.LEVEL_IN_FORCE,
          *(topics.actuator_frame(n) for n in ("mud_pump", "choke"))), optional=True),
    Node("wits0_gateway", "drill_gateway.wits0_node", "Wits0GatewayNode", (),
         (topics.MEASUREMENT, *(topics.actuator_frame(n) for n in ("mud_pump", "choke"))),
         optional=True),
    Node("plant", "drill_plant.plant_node", "PlantNode",
         (topics.MEASUREMENT, topics.TRUTH, topics.RIG_EVENTS, CLOCK), (*FRAMES, topics.FLOOR),
         plant=True, truth_side=True),
    Node("driller", "drill_string.ros.driller_node", "DrillerNode", (topics.DRILLING_COMMAND,),
         (topics.SURFACE,), kinds=("drilling",)),
    *(_drilling_actuator(name) for name in topics.DRILLING_ACTUATORS),
    Node("drilling_plant", "drill_string.ros.plant_node", "DrillingPlantNode",
         (topics.SURFACE, topics.DOWNHOLE, topics.DRILLING_TRUTH, CLOCK), DRILLING_FRAMES,
         kinds=("drilling",), plant=True),
)
BY_NAME = {n.name: n for n in NODES}
CONTROLLERS = tuple(n.controller for n in NODES if n.controller)
OPTIONAL = tuple(n.name for n in NODES if n.optional)
# The plant starts frame 0 once these are matched: everything the lockstep passes on, and
# the scenario events the recorder must not miss.
LOCKSTEP_TOPICS = (topics.MEASUREMENT, topics.TRUTH, topics.RIG_EVENTS, topics.ESTIMATE, CLOCK,
                   topics.COMMAND, topics.MACHINE_COMMAND, *FRAMES, topics.FLOOR, topics.SURFACE,
                   topics.DOWNHOLE, topics.DRILLING_TRUTH, topics.DRILLING_COMMAND,
                   *DRILLING_FRAMES)


# Process layouts: the groups of nodes that share one process (a container, one executor;
# drill_ros.container); every node not in a group runs in a process of its own. The
# recorder always runs alone, so a dying node cannot take the recording with it.
# A drilling run groups its nodes the same way: the drives with the actuators, the
# drilling plant with the plant, the driller with the advisors.
_ACTUATORS = (*topics.ACTUATORS, *topics.DRILLING_ACTUATORS)
_PLANT = ("plant", "drilling_plant", "rig_floor", *_ACTUATORS)
LAYOUTS = {
    "separate": {},
    "actuators": {"actuators": _ACTUATORS},
    "plant": {"plant": _PLANT},
    "two": {"plant": _PLANT,
            "control": ("estimator", *(n.name for n in NODES if n.controller), "protection",
                        "driller")},
}



def default_layout(realtime: bool, split: bool = False) -> str:
    """The layout a run takes when none is asked for: a fast run on one host the
    two-process layout (its recording is the separate layout's bit for bit and it costs less
    CPU and wall, docs/benchmarks.md); a realtime run, or a host's share of a split run,
    a process per node (what the realtime margins and the split runs were measured with)."""
    return "separate" if realtime or split else "two"


class SelectionError(ValueError):
    """A split run's share (``rig run --nodes``) that cannot be launched: the reason."""


# A host's share of a split run (``rig run --nodes``, docs/multihost.md) is named by node
# names and these groups; each group stands for its members that are in the run.
HOST_GROUPS = {
    "actuators": _ACTUATORS,
    "controller": (*(n.name for n in NODES if n.controller), "driller"),
}


def host_nodes(selection: str, nodes: list[Node]) -> list[Node]:
    """The nodes of the run ``nodes`` that ``selection`` (a comma list of node names and
    HOST_GROUPS) picks, in run order. A name that is neither, or a node that this run does
    not hold, is an error naming what is allowed."""
    names = [part.strip() for part in selection.split(",") if part.strip()]
    if not names:
        raise SelectionError(f"--nodes {selection!r}: no node named")
    in_run = {n.name for n in nodes}
    allowed = (*HOST_GROUPS, *(n.name for n in nodes))
    picked = set()
    for name in names:
        if name in HOST_GROUPS:
            picked |= in_run & set(HOST_GROUPS[name])
        elif name in in_run:
            picked.add(name)
        elif name in BY_NAME:
            raise SelectionError(f"--nodes: node {name!r} is not in this run; allowed: "
                                 f"{', '.join(allowed)}")
        else:
            raise SelectionError(f"--nodes: unknown node or group {name!r}; allowed: "
                                 f"{', '.join(allowed)}")
    if not picked:
        raise SelectionError(f"--nodes {selection!r}: no node of this run; allowed: "
                             f"{', '.join(allowed)}")
    return [n for n in nodes if n.name in picked]


def process_groups(layout: str, nodes: list[Node]) -> list[tuple[str, list[Node]]]:
    """The processes of a run in ``layout``: (process name, its nodes) in the order of
    ``nodes``, a group where its first member stands; a group with one node of this run
    is that node's own process."""
    if layout not in LAYOUTS:
        raise ValueError(f"layout {layout!r} is not one of {', '.join(LAYOUTS)}")
    group_of = {member: group for group, members in LAYOUTS[layout].items()
                for member in members}
    present = {group: [n for n in nodes if group_of.get(n.name) == group]
               for group in LAYOUTS[layout]}
    out, placed = [], set()
    for node in nodes:
        group = group_of.get(node.name)
        if group is None or len(present[group]) < 2:
            out.append((node.name, [node]))
        elif group not in placed:
            placed.add(group)
            out.append((group, present[group]))
    return out


def local_topics(members: list[Node], nodes: list[Node]) -> frozenset[str]:
    """The topics a process holding ``members`` takes on its local bus
    (drill_ros.local_bus): reliable topics a member subscribes to that no node of
    ``nodes`` outside the process publishes."""
    names = {m.name for m in members}
    out = set()
    for topic in TOPICS:
        publishers = [n.name for n in nodes if topic.name in n.publishes]
        if (topic.qos in LOSSLESS and publishers and set(publishers) <= names
                and any(topic.name in m.subscribes for m in members)):
            out.add(topic.name)
    return frozenset(out)


def local_subscriptions(layout: str, nodes: list[Node]) -> dict[str, frozenset[str]]:
    """Node name -> the topics it takes on its process's local bus, in ``layout``: the
    local topics, and each reliable topic published elsewhere that an earlier member also
    subscribes to (the process takes it once and shares it, drill_ros.local_bus)."""
    out = {}
    for _, members in process_groups(layout, nodes):
        if len(members) > 1:
            local = local_topics(members, nodes)
            taken: set[str] = set()
            for m in members:
                shared = {t for t in m.subscribes
                          if t not in local and t in taken and not latched(t)}
                taken |= set(m.subscribes)
                out[m.name] = frozenset(local & set(m.subscribes) | shared)
    return out


def _middleware_readers(topic: str, nodes: list[Node], local: dict) -> int:
    """Subscriptions to ``topic`` made in the middleware (local ones are not)."""
    return sum(n.subscribes_to(topic) and topic not in local.get(n.name, ()) for n in nodes)


def run_nodes(controller: str, fast: bool, kind: str = "tripping",
              extras: tuple[str, ...] = (), multi_stand: bool = False) -> list[Node]:
    """The nodes of a run of a ``kind`` scenario under ``controller``, recorder first and
    plant last. Tripping: the actuators, the estimator, the controller's advisor with the
    process protection, the console in realtime mode, and the rig floor when the scenario
    trips stands (``multi_stand``). Drilling (controller ``none``): the driller, the top
    drive, the block feed and the drilling plant. ``extras``: the optional nodes
    (OPTIONAL) this run holds too."""
    if kind not in SCENARIO_KINDS:
        raise ValueError(f"scenario kind {kind!r} is not one of {', '.join(SCENARIO_KINDS)}")
    if controller not in CONTROLLERS + ("none",):
        raise ValueError(f"controller {controller!r} is not one of {', '.join(CONTROLLERS)}, none")
    for name in extras:
        if name not in OPTIONAL:
            raise ValueError(f"optional node {name!r} is not one of {', '.join(OPTIONAL)}")
        if kind not in BY_NAME[name].kinds:
            raise ValueError(f"{name} does not run in a {kind} scenario (only "
                             f"{', '.join(BY_NAME[name].kinds)})")
    advisor = [n for n in NODES if n.controller == controller]
    out = []
    for node in NODES:
        if kind not in node.kinds or (node.controller and node not in advisor):
            continue
        if node.name == "protection" and not advisor:
            continue
        if (node.realtime_only and fast) or (node.optional and node.name not in extras):
            continue
        if node.multi_stand and not multi_stand:
            continue
        out.append(node)
    return out


def lockstep_endpoints(nodes: list[Node], fast: bool, local: dict | None = None) -> list[str]:
    """``sub@topic:N`` / ``pub@topic:N`` the plant waits for: every subscriber (but the
    ``local`` ones, local_subscriptions) and every publisher other than the plant itself of
    each lockstep topic in this node set."""
    out = []
    for topic in LOCKSTEP_TOPICS:
        if topic == CLOCK:
            readers = sum(n.reads_clock for n in nodes)
            if fast and readers:
                out.append(f"sub@{CLOCK}:{readers}")
            continue
        publishers = [n for n in nodes if topic in n.publishes]
        if not publishers:
            continue
        subscribers = _middleware_readers(topic, nodes, local or {})
        if subscribers:
            out.append(f"sub@{topic}:{subscribers}")
        others = sum(not n.plant for n in publishers)
        if others:
            out.append(f"pub@{topic}:{others}")
    return out


def first_publish_matches(node: Node, nodes: list[Node], local: dict | None = None) -> list[str]:
    """``topic:N`` for each reliable topic ``node`` publishes in this node set, its status
    topic and /diagnostics included: the subscriptions (in the middleware: not the ``local`` ones, nor
    ``node``'s own) its publisher must have matched before its first message. DDS matches
    a publisher with a subscription some time after the graph shows both (the plant's
    ``wait_for``, the recorder's discovery); a first sample published before that is lost
    to that reader: the lockstep would wait for it forever, the recording would miss it.
    Latched topics need no gate: a late reader still gets their last value."""
    out = []
    others = [n for n in nodes if n is not node]
    for topic in (*node.publishes, node.status_topic, topics.DIAGNOSTICS):
        if latched(topic):
            continue
        readers = sum(n.reads_clock for n in others) if topic == CLOCK else \
            _middleware_readers(topic, others, local or {})
        if readers:
            out.append(f"{topic}:{readers}")
    return out


def _frames_of(node: Node) -> str:
    """A node's name, with the actuators whose frames it reads when not all of them."""
    names = [a for a, f in zip(topics.ACTUATORS, FRAMES) if f in node.subscribes]
    return node.name if len(names) == len(FRAMES) else f"{node.name} ({', '.join(names)})"


def markdown_table() -> str:
    """docs/architecture.md's topic table: who publishes and who subscribes, per topic
    (the recorder, and the Foxglove bridge when asked for, take every topic; ``<name>``
    stands for each actuator)."""
    every = ", ".join(n.name for n in NODES if EVERY_TOPIC in n.subscribes)
    rows = [f"| topic | type | publishers | subscribers (besides {every}) | QoS |",
            "| --- | --- | --- | --- | --- |"]
    frame = topics.actuator_frame("<name>")
    seen = set()
    for t in TOPICS:
        name = frame if t.name in FRAMES else t.name
        if name in seen:
            continue
        seen.add(name)
        pubs = ["every node"] if t.name == topics.DIAGNOSTICS else \
            [n.name for n in NODES if t.name in n.publishes]
        subs = [n.name for n in NODES if t.name in n.subscribes]
        if t.name in FRAMES:
            pubs = ["`<name>` (each tripping actuator)"]
            subs = [_frames_of(n) for n in NODES if any(f in n.subscribes for f in FRAMES)]
        qos = describe_qos(QOS_PROFILES[t.qos])
        note = f" ({t.note})" if t.note else ""
        rows.append(f"| `{name}` | `{t.type}`{note} | {', '.join(pubs)} | "
                    f"{', '.join(subs) or '—'} | {qos} |")
    return "\n".join(rows)


if __name__ == "__main__":
    sys.stdout.write(markdown_table() + "\n")
