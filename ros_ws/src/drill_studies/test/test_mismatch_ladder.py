"""The mismatch ladder's parts and its verdict per row (drill_studies.mismatch_ladder):
each part's *before* is a valid configuration that differs from the committed one, and
the part named for a row is the one whose absence alone costs it the most."""
import pytest

from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_core.yaml_files import dotted_items
from drill_studies import mismatch_ladder as ml


def _value(config, path: str):
    node = config
    for key in path.split("."):
        node = getattr(node, key)
    return node


@pytest.mark.parametrize("part", ml.PARTS, ids=[p[0] for p in ml.PARTS])
def test_each_part_switched_back_is_a_valid_configuration_that_differs(part):
    _, overrides = part
    committed, before = load_rig(config_dir()), load_rig(config_dir(), overrides)
    for path, value in dotted_items(overrides):
        assert _value(before, path) == value
        assert _value(committed, path) != value, f"{path} is already {value}: nothing measured"
    load_rig(config_dir(), ml.BEFORE)                        # all of them at once


def _row(rung: str, settled_bar: float) -> dict:
    return {"member": "yield_high", "rung": rung, "seed": 2, "alarms": 0, "legs_s": [58.0, 59.0],
            "bhp_rmse_settled_pa": settled_bar * 1e5, "bhp_time_outside_settled_s": 0.0}


def test_the_part_needed_most_is_the_costliest_absence():
    rows = [_row("NMPC", 0.30), _row("NMPC without the density offset state", 0.32),
            _row("NMPC without the prediction's sharp yield jump", 0.45),
            _row("NMPC without the integral's leak", 0.33)]
    assert ml._needed_most(rows, "yield_high", "NMPC") == \
        "the prediction's sharp yield jump (+0.15 bar)"
    close = [_row("NMPC", 0.30), _row("NMPC without the integral's leak", 0.34)]
    assert ml._needed_most(close, "yield_high", "NMPC").startswith("none alone")
