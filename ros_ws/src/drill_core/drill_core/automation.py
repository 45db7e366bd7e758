"""Automation levels of the D-WIS model (docs/design.md §10): who drives the machines.

``manual``: the operator; ``advisory``: the controller computes but the operator's panel
drives; ``closed_loop``: the controller's commands reach the machines through the
process protection.
"""

AUTOMATION_LEVELS = ("manual", "advisory", "closed_loop")
