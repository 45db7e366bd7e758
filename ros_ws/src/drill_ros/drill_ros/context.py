"""Parameters every rig node takes: config_dir, scenario, mode (fast | realtime)."""
from __future__ import annotations

from dataclasses import dataclass

from drill_core import hydraulics as hy
from drill_core.config import RigConfig
from drill_core.mismatch import read_truth_file, truth_config
from drill_core.operating_point import OperatingPoint, initial_operating_point
from drill_core.rig_root import rig_root
from drill_core.scenario import Scenario, load_scenario_config

MODES = ("fast", "realtime")


@dataclass(frozen=True)
class NodeContext:
    scenario: Scenario
    config: RigConfig
    mode: str
    well_model: hy.WellModel
    operating_point: OperatingPoint     # where the run starts (the scenario's initial)

    @property
    def fast(self) -> bool:
        return self.mode == "fast"


def common_parameters(node, default_scenario: str) -> tuple[str, str, str]:
    """Declare and read the parameters every node of a run gets: (config_dir, scenario
    path, mode); unset or empty, config/ and config/scenarios/<default_scenario>.yaml."""
    root = rig_root()
    defaults = {"config_dir": str(root / "config"),
                "scenario": str(root / "config" / "scenarios" / f"{default_scenario}.yaml")}
    config_dir, scenario_path = (node.declare_parameter(name, default).value or default
                                 for name, default in defaults.items())
    return config_dir, scenario_path, node.declare_parameter("mode", "fast").value


def load_context(node, truth_side: bool = False) -> NodeContext:
    """Declare and read the common parameters, then load scenario and configuration once.
    ``truth_side`` (the plant and the actuators): also the ``truth`` parameter, a file of
    the plant's mismatch (drill_core.mismatch, as the launcher writes it; "" none), applied
    to the configuration."""
    config_dir, scenario_path, mode = common_parameters(node, "case2")
    if mode not in MODES:
        raise ValueError(f"parameter mode: {mode!r} is not one of {', '.join(MODES)}")
    scenario, config = load_scenario_config(scenario_path, config_dir)
    if truth_side:
        truth_path = node.declare_parameter("truth", "").value
        if truth_path:
            config = truth_config(config, read_truth_file(truth_path)[1])
    wm = hy.rig_well_model(config, scenario.pulled_at_start_m)
    return NodeContext(scenario, config, mode, wm, initial_operating_point(wm, scenario.initial))
