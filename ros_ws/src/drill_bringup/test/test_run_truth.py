"""A run's plant mismatch is checked before anything is launched: a truth the plant cannot
take is refused with its key and reason, and no run directory is left behind; a good
inline truth tags the run directory, as a named one does."""
from pathlib import Path

import pytest
import yaml

from drill_bringup import runs
from drill_core.config import ConfigError

CASE2 = runs.ROOT / "config" / "scenarios" / "case2.yaml"


def _scenario(tmp_path: Path, truth) -> Path:
    data = yaml.safe_load(CASE2.read_text())
    data["truth"] = truth
    path = tmp_path / "case2_truth.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("truth, words", [
    ({"hole_diameter_factors": [1.0, 1.1]}, ("hole_diameter_factors", "one factor per annulus segment")),
    ({"flow_index_offset": 0.3}, ("flow_index_offset", "outside [0.1, 1]")),
])
def test_a_truth_the_plant_cannot_take_is_refused_before_launch(tmp_path, runs_dir, truth, words):
    with pytest.raises(ConfigError) as info:
        runs.run_scenario(_scenario(tmp_path, truth), runs_dir=runs_dir, quiet=True)
    for word in words:
        assert word in str(info.value), str(info.value)
    assert not runs_dir.exists() or not any(runs_dir.iterdir())


def test_an_inline_truth_is_checked_and_named(tmp_path):
    name, mismatch = runs.run_truth(_scenario(tmp_path, {"density_factor": 1.01}), None)
    assert name == "inline" and mismatch.density_factor == 1.01
