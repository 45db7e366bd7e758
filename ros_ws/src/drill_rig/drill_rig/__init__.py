"""The rig's front: the ``rig`` command line (drill_rig.cli, ``scripts/rig``) and, for a
notebook or a script, ``simulate`` (a scenario's closed loop in this process) and
``load_run`` (a recorded run), both as pandas DataFrames with SI columns named with their
units (drill_rig.api; docs/python-api.md)."""
from drill_rig.api import RunError, load_run, scenarios, simulate

__all__ = ["RunError", "load_run", "scenarios", "simulate"]
