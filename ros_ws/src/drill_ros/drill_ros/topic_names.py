"""Topic and service names of the graph (docs/design.md §2), without their QoS
(drill_ros.topics): plain Python, for the code that reads recordings.
"""
from drill_core.events import ACTUATORS  # noqa: F401  (re-exported: the actuator topics)

MEASUREMENT = "/rig/measurement"        # drill_msgs/RigMeasurement, plant -> estimator, actuators
TRUTH = "/rig/truth"                    # drill_msgs/PlantTruth, evaluation only
COMMAND = "/supervisor/command"         # drill_msgs/RigCommand, advisor (nmpc, baseline) -> protection
MACHINE_COMMAND = "/rig/command"        # drill_msgs/RigCommand, protection -> actuators
EMERGENCY_STOP = "/operator/emergency_stop"  # std_msgs/Bool, latched
AUTOMATION_LEVEL = "/operator/automation_level"  # std_msgs/String, latched: manual|advisory|closed_loop
PROTECTION_EVENTS = "/protection/events"     # drill_msgs/OperatorEvent: clamps and alarms
LEVEL_IN_FORCE = "/protection/automation_level"   # std_msgs/String, latched: the level applied
ESTOP_IN_FORCE = "/protection/emergency_stop"     # std_msgs/Bool, latched: the stop applied
ESTIMATE = "/estimator/estimate"        # drill_msgs/StateEstimate
NMPC_STATUS = "/nmpc/status"            # drill_msgs/NmpcStatus
NMPC_NODE_STATUS = "/nmpc/node_status"  # drill_msgs/NodeStatus of the nmpc node (/nmpc/status is taken)
SETPOINTS = "/setpoints"                # drill_msgs/Setpoints, latched
SET_SETPOINTS = "/set_setpoints"        # drill_msgs/srv/SetSetpoints, validating
OPERATOR_EVENTS = "/operator/events"    # drill_msgs/OperatorEvent
DIAGNOSTICS = "/diagnostics"            # diagnostic_msgs/DiagnosticArray, every node: its health (drill_ros.diagnostics)
RIG_EVENTS = "/rig/events"              # drill_msgs/OperatorEvent, plant: scenario events (faults)
FLOOR = "/rig/floor"                    # drill_msgs/RigFloor, rig floor (a multi-stand trip) -> plant, drawworks, mud pump, estimator, advisor, protection
# drilling mode (drill_string): its own node set
SURFACE = "/drilling/surface"           # drill_msgs/SurfaceMeasurement, drilling plant -> driller, drives
DOWNHOLE = "/drilling/downhole"         # drill_msgs/DownholeMeasurement, drilling plant (wired pipe)
DRILLING_TRUTH = "/drilling/truth"      # drill_msgs/DrillingTruth, drilling plant: evaluation only
DRILLING_COMMAND = "/drilling/command"  # drill_msgs/DrillingCommand, driller -> top drive, block feed
DRILLING_ACTUATORS = ("top_drive", "block_feed")   # drilling mode's machines (actuator_frame)
WATCHED_ACTUATORS = ("drawworks", "choke")  # whose frames the protection reads (actuator_watch)


def actuator_frame(name: str) -> str:
    """drill_msgs/ActuatorFrame topic of one actuator."""
    return f"/actuators/{name}/frame"


def status(node: str) -> str:
    """drill_msgs/NodeStatus topic of one node."""
    return f"/{node}/status"
