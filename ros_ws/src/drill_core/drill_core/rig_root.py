"""Where the rig's checkout is: its ``config/`` and ``runs/`` hang off it.

``RIG_ROOT`` when set (``scripts/env.sh`` sets it); else the checkout this code is in,
when the package runs from the source tree (the workspace's symlinked install resolves
there); else the working directory.
"""
from __future__ import annotations

import os
from pathlib import Path

_CHECKOUT = Path(__file__).resolve().parents[4]    # <root>/ros_ws/src/drill_core/drill_core


def rig_root() -> Path:
    """The rig's checkout (see the module's docstring for the order)."""
    if "RIG_ROOT" in os.environ:
        return Path(os.environ["RIG_ROOT"])
    if (_CHECKOUT / "config" / "well.yaml").is_file():
        return _CHECKOUT
    return Path.cwd()


def config_dir() -> Path:
    """The checkout's rig configuration (config/)."""
    return rig_root() / "config"
