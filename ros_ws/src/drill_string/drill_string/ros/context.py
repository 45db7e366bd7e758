"""Parameters every drilling node takes (config_dir, scenario, mode) and what they load:
the drilling scenario and config/drilling.yaml with its overrides
(drill_string.scenario). Drilling runs in fast mode only."""
from __future__ import annotations

from dataclasses import dataclass

from drill_ros.context import common_parameters

from drill_string.scenario import DrillingRig, DrillingScenario, load_drilling_scenario


@dataclass(frozen=True)
class DrillingContext:
    scenario: DrillingScenario
    rig: DrillingRig


def load_drilling_context(node) -> DrillingContext:
    """Declare and read the common parameters, then load scenario and configuration once."""
    config_dir, scenario_path, mode = common_parameters(node, "drilling_12in_op1")
    if mode != "fast":
        raise ValueError(f"parameter mode: {mode!r}; a drilling run is fast mode only")
    return DrillingContext(*load_drilling_scenario(scenario_path, config_dir))
